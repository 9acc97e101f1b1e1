# Two entry points for a fresh machine (Python 3.11+ and PyPI only); each makes .venv on first use
# and compiles the numba kernel of re-solves into numba's cache (20-30 s, once): no solve
# waits. `demo` installs what running needs (the package, plots, Clarabel); `test` adds the test
# toolchain (pytest, linters, peers, example robots, MuJoCo, Dask) to the same .venv.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
RUNTIME := $(VENV)/.runtime-installed
TESTING := $(VENV)/.test-installed

.PHONY: demo test validate docs clean

$(RUNTIME): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[plot,fast]"
	$(BIN)/clearance-pin compile
	touch $@

$(TESTING): $(RUNTIME)
	$(BIN)/python -m pip install --quiet -e ".[test,plot,fast,distributed]"
	touch $@

demo: $(RUNTIME)
	mkdir -p out
	$(BIN)/clearance-pin solve models/arm_6r.urdf --exact --output tool --plot out/demo.png

# lint and types first (seconds), then the suite with one BLAS thread: the solver's matrices are
# small, and threads fight on a busy machine.
test: $(TESTING)
	$(BIN)/ruff check clearance_pin tests benchmarks validation examples docs/build_api.py
	$(BIN)/ruff format --check clearance_pin tests benchmarks validation examples docs/build_api.py
	$(BIN)/mypy clearance_pin
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(BIN)/python -m pytest

validate: $(TESTING)
	$(BIN)/python validation/younes2013.py --json out/younes2013.json

# the API reference from the docstrings (pdoc), out/api/index.html
docs: $(TESTING)
	$(BIN)/python docs/build_api.py out/api

clean:
	rm -rf $(VENV) out
