# Two commands on a fresh machine:  `make run` (the main job) and `make test` (the test suite).
# Each creates and uses a local virtual environment in .venv.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: run test test-all bench clean

WARM_UP := $(VENV)/.warm-up

# Byte-compile the package's sources before every command: where the environment sets
# PYTHONDONTWRITEBYTECODE (as these machines do), every process would otherwise compile
# the package's modules again at import (0.4 s of each process start; the CLI tests,
# which run the installed command, took 9.1 s against 2.7 s). Up-to-date files are skipped.
COMPILE := $(PY) -m compileall -q src > /dev/null

# The install ends with a small identification end to end (8 simulated maneuvers, one
# process): it compiles numba's kernels (filter, location, basis, evaluation) into numba's
# cache once, so that the first main job does not compile them in each of its workers.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[all,test]'
	$(COMPILE)
	rm -rf $(WARM_UP)
	$(VENV)/bin/simplexspline identify --maneuvers 8 --workers 1 --quiet -o $(WARM_UP)
	rm -rf $(WARM_UP)
	touch $(STAMP)

run: $(STAMP)
	$(COMPILE)
	$(VENV)/bin/simplexspline identify -o identification

test: $(STAMP)
	$(COMPILE)
	$(PY) -m pytest -m "not slow"

test-all: $(STAMP)
	$(COMPILE)
	$(PY) -m pytest

bench: $(STAMP)
	$(COMPILE)
	$(PY) benchmarks/run.py

clean:
	rm -rf $(VENV) .pytest_cache build dist
