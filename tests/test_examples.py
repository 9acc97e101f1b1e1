"""Every script of examples/ runs as written, from the repository's root, its pictures written to
a temporary folder (issue 24: an examples folder run by the tests)."""

from __future__ import annotations

import importlib.metadata
import os
import subprocess
import sys

import pytest
from conftest import ROOT

SCRIPTS = sorted((ROOT / "examples").glob("*.py"))


def test_every_example_is_listed_in_the_examples_readme():
    listed = (ROOT / "examples" / "README.md").read_text()
    assert SCRIPTS and all(f"`{script.name}`" in listed for script in SCRIPTS)


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_the_example_runs(script, tmp_path):
    if script.stem == "vendor_robot_clearance_file":
        try:
            importlib.metadata.distribution("example-robot-data")
        except importlib.metadata.PackageNotFoundError:
            pytest.skip("example-robot-data is not installed (the test extra)")
    environment = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path)], cwd=ROOT, env=environment,
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip()
    for picture in tmp_path.glob("*.png"):
        assert picture.stat().st_size > 10_000
