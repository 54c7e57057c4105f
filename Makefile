# The README's first two commands: `make report` (main job) and `make test` (tests).
# Both run the full set-up first (scripts/setup.sh: libLLVM for Mitsuba, .venv, C++ build).
VENV ?= .venv
PY := $(VENV)/bin/python
PRESET ?= quick

.PHONY: setup report test test-slow clean

setup:
	bash scripts/setup.sh

report: setup
	$(VENV)/bin/rtbench run --preset $(PRESET) --format html,svg,pdf,csv

test: setup
	$(PY) -m pytest

test-slow: setup
	$(PY) -m pytest -m slow

clean:
	rm -rf build $(VENV) .pytest_cache
