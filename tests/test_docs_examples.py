"""The examples of the docs run: the package docstring's doctest (its printed values are the
library's answer on the bundled model; their closed form is checked in the paper-case tests)."""

from __future__ import annotations

import doctest

from conftest import ROOT

import clearance_pin


def test_the_package_docstring_example_runs(monkeypatch):
    """``import clearance_pin``'s docstring example, from the repository's root."""
    monkeypatch.chdir(ROOT)
    failures, tried = doctest.testmod(clearance_pin, verbose=False, report=True)
    assert tried >= 4 and failures == 0
