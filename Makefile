# Two entry points (see README): `make demo` runs the main job, `make test` runs the tests.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
DATASETS ?= ../shared/datasets

.PHONY: demo test bench install clean

$(BIN)/fuzzybrep: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	@# bytecode, as pip compiles an installed package's: an editable install has none, and with
	@# PYTHONDONTWRITEBYTECODE set every command would compile the package again at start-up
	$(BIN)/python -m compileall -q src >/dev/null
	@touch $@

install: $(BIN)/fuzzybrep

demo: install
	$(BIN)/fuzzybrep demo --out out/demo

test: install
	$(BIN)/python -m pytest -q

bench: install
	$(BIN)/python benchmarks/run.py --readme README.md --docs docs

clean:
	rm -rf $(VENV) out .pytest_cache
