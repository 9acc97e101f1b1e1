"""The warm-start bet: the cheaper route wins, and the other one is re-tried now and then."""

from __future__ import annotations

from clearance_pin.equilibrium.cone_solver import WarmBet


def _run(bet, warm_time, cold_time, solves):
    routes = []
    for _ in range(solves):
        warm = bet.worth_it()
        bet.record(warm, warm_time if warm else cold_time)
        routes.append(warm)
    return routes


def test_the_cheaper_route_is_taken_and_the_other_retried():
    bet = WarmBet()
    routes = _run(bet, warm_time=2e-3, cold_time=1e-3, solves=200)
    assert routes[: WarmBet.PROBATION] == [True] * WarmBet.PROBATION  # warm first
    later = routes[50:]
    assert 0 < sum(later) <= len(later) // WarmBet.RETRY_EVERY + 1  # cold, warm now and then
    bet = WarmBet()
    later = _run(bet, warm_time=1e-4, cold_time=1e-3, solves=200)[50:]
    assert len(later) - sum(later) <= len(later) // WarmBet.RETRY_EVERY + 1


def test_the_bet_follows_a_change():
    bet = WarmBet()
    _run(bet, warm_time=2e-3, cold_time=1e-3, solves=100)
    routes = _run(bet, warm_time=1e-4, cold_time=1e-3, solves=100)  # loads now close together
    assert sum(routes[-50:]) >= 50 - 50 // WarmBet.RETRY_EVERY - 2
