# Two commands on a fresh machine:  `make run` (the main job) and `make test` (the test suite).
# Each creates and uses a local virtual environment in .venv.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: run test test-all bench clean

WARM_UP := $(VENV)/.warm-up

# The install ends with a small identification end to end (8 simulated maneuvers, one
# process): it compiles numba's kernels (filter, location, basis, evaluation) into numba's
# cache once, so that the first main job does not compile them in each of its workers.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[all,test]'
	rm -rf $(WARM_UP)
	$(VENV)/bin/simplexspline identify --maneuvers 8 --workers 1 --quiet -o $(WARM_UP)
	rm -rf $(WARM_UP)
	touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/simplexspline identify -o identification

test: $(STAMP)
	$(PY) -m pytest -m "not slow"

test-all: $(STAMP)
	$(PY) -m pytest

bench: $(STAMP)
	$(PY) benchmarks/run.py

clean:
	rm -rf $(VENV) .pytest_cache build dist
