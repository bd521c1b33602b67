# The two commands of the quick start: `make demo` and `make test`.
# Both create the virtual environment at .venv/ on first use; nothing else is needed
# beyond Python >= 3.11, git and make.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup sysdeps demo test lint typecheck unit ros2-setup ros2-test campaign bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

## ROS 2 (actorswarm[ros2]) in a virtual environment of its own, .venv-ros2/: the ROS 2
## wheels install a start-up hook that re-executes every Python interpreter of their
## environment once with LD_LIBRARY_PATH set, which the daemons, the test workers and the
## benchmarks of .venv/ are kept from (docs/ros2.md, "Install"). About 50 s and 700 MB.
ROS2_VENV := .venv-ros2
ROS2_STAMP := $(ROS2_VENV)/.installed

$(ROS2_STAMP): pyproject.toml
	$(PYTHON) -m venv $(ROS2_VENV)
	$(ROS2_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(ROS2_VENV)/bin/python -m pip install --quiet -e '.[ros2]' 'pytest>=8' 'hypothesis>=6.100'
	touch $(ROS2_STAMP)

ros2-setup: $(ROS2_STAMP)

## The ROS 2 tests against the real rclpy (in .venv-ros2; in .venv they skip).
ros2-test: $(ROS2_STAMP)
	$(ROS2_VENV)/bin/python -m pytest tests/ros2 -q

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
test: lint typecheck unit ros2-test

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
	rm -rf $(VENV) $(ROS2_VENV) .mypy_cache .pytest_cache .ruff_cache
