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

## The main job: the paper's branch-and-merge task script (Fig. 7) run by ten simulated
## platforms on a lossy radio, then a swarm that loses its master mid-barrier, reboots it,
## is partitioned and heals — every invariant checked.
demo: $(STAMP)
	$(BIN)/actorswarm sim examples/branch_merge.xml --no-world --loss 0.1 --duration 12 \
		--event AtoBC_branch_event@5 --event finish_event@10
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
