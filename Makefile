# Every target sets itself up on a fresh machine: .venv is created if missing and the project is
# (re)installed with its test extra only when pyproject.toml changed since the last install.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.install-stamp

.PHONY: install demo test bench validation-docs clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	rm -rf runs/demo-continuous  # the demo's own directory: a run never writes into a used one
	$(BIN)/nodesim run scenarios/lab/continuous.toml --out runs/demo-continuous

# the suite on TEST_WORKERS processes (pytest-xdist; 0: in this one), each taking whole files, in order (tests
# that read what an earlier test of their file recorded need it): 4.6 min against 10 min in one process on 2 cores
# (2026-12-07)
TEST_WORKERS ?= 2

test: $(STAMP)
	$(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile

bench: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[test,bench]'
	$(BIN)/nodesim bench --json --write benchmarks/latest.json

# the validation counts and table of README.md and docs/validation.md, from a real `nodesim validate` run (minutes)
validation-docs: $(STAMP)
	mkdir -p runs
	$(BIN)/nodesim validate --json > runs/validation.json
	$(BIN)/python scripts/validation_table.py runs/validation.json

clean:
	rm -rf $(VENV) runs .pytest_cache .hypothesis
