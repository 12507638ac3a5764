# Two commands do everything on a fresh machine:
#   make run    install, then train every trial of suites/quick.yaml into runs/quick/ (not
#               committed), draw its figure and compare it with the committed results/quick/
#               (pooled with results/quick-draws: 55 seeds a cell)
#   make test   install, then lint, build the docs site (strict: a broken link fails) and run the
#               test suite
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
SUITE ?= suites/quick.yaml
NAME := $(basename $(notdir $(SUITE)))
RUN ?= runs/$(NAME)
# the committed reference, pooled with more seeds of it where there are (results/quick-draws)
REFERENCE ?= $(wildcard results/$(NAME) results/$(NAME)-draws)

.PHONY: install run test test-fast bench docs clean

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	# torch first, pinned: the CPU wheel. Unpinned, pip would pull gigabytes of CUDA packages.
	$(BIN)/python -m pip install -q torch==2.13.0
	$(BIN)/python -m pip install -q -e '.[test,distributed]'
	touch $@

install: $(BIN)/.installed

run: install
	# --no-reuse: train every trial here, rather than link the committed ones it is checked against
	$(BIN)/bench run $(SUITE) --results $(RUN) --no-reuse
	$(BIN)/bench plot $(RUN)
	$(BIN)/bench compare $(RUN) $(REFERENCE)

# pytest -n 2: most tests run in one process, so two workers keep both cores of a laptop busy.
# --dist worksteal: each worker starts on half the tests in order (a module's tests, and its
# module fixture, mostly on one worker), and one that runs out takes over the other's rest.
test: install
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet --site-dir build/site
	$(BIN)/python -m pytest -q -n 2 --dist worksteal

# While developing: everything but the tests marked slow (real training, whole suites), ~2 min.
test-fast: install
	$(BIN)/python -m pytest -q -n 2 --dist worksteal -m "not slow"

docs: install
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs serve

bench: install
	$(BIN)/python benchmarks/throughput.py

clean:
	rm -rf .cache .pytest_cache
