"""The warm-start bet: warm starts go on while they pay, and are re-tried now and then."""

from __future__ import annotations

from clearance_pin.equilibrium.cone_solver import WarmBet


def test_failing_warm_starts_are_skipped_then_retried():
    bet = WarmBet()
    for _ in range(WarmBet.PROBATION):
        assert bet.worth_it()
        bet.record(False)
    decisions = [bet.worth_it() for _ in range(3 * WarmBet.RETRY_EVERY)]
    assert sum(decisions) == 3  # one retry every RETRY_EVERY solves
    assert decisions[WarmBet.RETRY_EVERY - 1] and not any(decisions[: WarmBet.RETRY_EVERY - 1])


def test_paying_warm_starts_go_on_and_the_record_follows_the_recent_past():
    bet = WarmBet()
    for _ in range(100):
        assert bet.worth_it()
        bet.record(True)
    assert bet.attempts < WarmBet.MEMORY  # halved: old successes fade
    while bet.worth_it():  # the loads drift apart: failures take over
        bet.record(False)
    assert 2 * bet.successes < bet.attempts
