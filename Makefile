# The two commands of the quick start: `make demo` and `make test`.
# Both create the virtual environment at .venv/ on first use; nothing else is needed
# beyond Python >= 3.11, git and make.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup sysdeps demo test lint typecheck unit campaign bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

## The main job: the paper's 30-UAV formation mission in the simulator (arrow, two arrows,
## a branch into a line, six arrows, herringbone, return), with progress, the pictures of
## the run in demo-out/ and a summary. `actorswarm demo --help` for the other missions.
demo: $(STAMP)
	$(BIN)/actorswarm demo --out demo-out

lint: $(STAMP)
	$(BIN)/ruff check src tests
	$(BIN)/ruff format --check src tests

typecheck: $(STAMP)
	$(BIN)/mypy

## The Debian packages only the tests need (chromium, nftables, iproute2): installed when
## missing and root, otherwise named (the tests that need them skip). Fast when present.
sysdeps:
	bash scripts/system-deps.sh

unit: $(STAMP) sysdeps
	$(BIN)/python -m pytest -n 2 --dist worksteal --durations=10

## Every check: linter, strict type checker, the whole test suite (with the seeded campaign).
test: lint typecheck unit

## A long seeded fault campaign, beyond the 200 seeds per mode of `make test`: COUNT seeds
## from START, each in both membership modes (star and broadcast), on every CPU. Prints each
## failure with the command that replays it; exit status 1 when any seed failed.
## `make campaign START=0 COUNT=500` for other seeds, `WORKERS=N` for fewer processes.
START ?= 100000
COUNT ?= 10000
campaign: $(STAMP)
	$(BIN)/actorswarm swarm campaign --start $(START) --count $(COUNT) --membership both $(if $(WORKERS),--workers $(WORKERS))

bench: $(STAMP)
	$(BIN)/actorswarm bench core

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache
