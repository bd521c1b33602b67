# The two commands of the quick start: `make demo` and `make test`.
# Both create the virtual environment at .venv/ on first use; nothing else is needed
# beyond Python >= 3.11, git and make.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup demo test lint typecheck unit campaign bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

## The main job: a simulated swarm that elects a master, synchronizes on barriers,
## loses its master mid-barrier and recovers, with every invariant checked.
demo: $(STAMP)
	$(BIN)/actorswarm swarm demo

lint: $(STAMP)
	$(BIN)/ruff check src tests
	$(BIN)/ruff format --check src tests

typecheck: $(STAMP)
	$(BIN)/mypy

unit: $(STAMP)
	$(BIN)/python -m pytest -n 2 --durations=10

## Every check: linter, strict type checker, the whole test suite (with the seeded campaign).
test: lint typecheck unit

bench: $(STAMP)
	$(BIN)/actorswarm bench core

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache
