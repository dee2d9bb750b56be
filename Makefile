# The two commands of the README: `make run` and `make test`. Each creates .venv.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: run test test-fast lint generate check-generated bench mutate clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# --no-compile: Python byte-compiles each module the first time it is imported, so only the
# modules in use are compiled (pip would compile every file of every package, ~25 s)
$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --no-compile -e ".[plot]"
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --no-compile -e ".[test]"
	touch $@ $(VENV)/.installed

## run: the main job on the embedded Heli4 default: the paper's numbers, then report.html
run: $(VENV)/.installed
	$(BIN)/eigentwist reproduce
	$(BIN)/eigentwist report -o report.html

## test: the whole suite, then the 15 slowest tests
test: $(VENV)/.installed-test
	$(BIN)/python -m pytest -n auto --dist loadgroup --durations=15

## test-fast: the inner loop (under 2 minutes): no compiler, no browser, no slow tests (seeds, README),
## no SymPy derivation (the checked-in evaluators only)
test-fast: $(VENV)/.installed-test
	EIGENTWIST_TEST_BACKEND=numpy $(BIN)/python -m pytest -n auto --dist loadgroup \
		-m "not compiled and not browser and not slow and not derives" --durations=15

## lint: ruff's lint rules and format check (configured in pyproject.toml)
lint: $(VENV)/.installed-test
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

## generate: regenerate eigentwist/generated (checked in)
generate: $(VENV)/.installed
	$(BIN)/eigentwist generate

check-generated: $(VENV)/.installed
	$(BIN)/eigentwist generate --check

bench: $(VENV)/.installed-test
	$(BIN)/python benchmarks/run.py

## mutate: mutation testing of the modules in [tool.mutmut] (pyproject.toml), score per module in
## tests/README.md; MUTANTS="eigentwist.outputs*" restricts the run to matching mutants
$(VENV)/.installed-dev: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test,dev]"
	touch $@ $(VENV)/.installed $(VENV)/.installed-test

mutate: $(VENV)/.installed-dev
	rm -rf mutants
	EIGENTWIST_TEST_BACKEND=numpy nice $(BIN)/mutmut run --max-children 1 $(MUTANTS)
	$(BIN)/mutmut results

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
