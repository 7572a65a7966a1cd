# trainctl developer tasks. On a fresh clone: `make report` and `make test`.
#
# The virtual environment lives in .venv; the install steps are recorded by
# stamp files inside it, so they re-run only when pyproject.toml (or the
# version) changes, or when .venv is deleted.

PYTHON ?= python3
# Another environment: `make docs VENV=.venv-docs` (.ci/run builds the docs in a fresh one).
VENV ?= .venv
BIN := $(VENV)/bin
PIP := $(BIN)/python -m pip --disable-pip-version-check
STAMP_RUN := $(VENV)/.trainctl-install.stamp
STAMP_TEST := $(VENV)/.trainctl-install-test.stamp
STAMP_DOCS := $(VENV)/.trainctl-install-docs.stamp
INSTALL_DEPS := pyproject.toml trainctl/__init__.py

.PHONY: help report test test-e2e docs dist install install-test install-docs lint clean

help:
	@echo "make report   write reports/crh2-dmpc.html (creates .venv when missing)"
	@echo "make test     run the test suite, doctests included, except the e2e group (minutes)"
	@echo "make test-e2e run the long end-to-end tests (pytest -m e2e); CI runs both"
	@echo "make docs     build the documentation into docs/_build/html (warnings are errors)"
	@echo "make dist     build the wheel (distribution trainctl-toolbox) into dist/"
	@echo "make lint     ruff check, mypy and the import contracts (lint-imports)"
	@echo "make clean    remove build artefacts and caches (keeps .venv)"

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# pip on this machine may print 'Location ... is ignored' configuration
# warnings; they are harmless, only pip's exit status counts.
$(STAMP_RUN): $(INSTALL_DEPS) | $(BIN)/python
	$(PIP) install --quiet -e .
	@touch $@

$(STAMP_TEST): $(INSTALL_DEPS) | $(BIN)/python
	$(PIP) install --quiet -e '.[test]'
	@touch $@ $(STAMP_RUN) $(STAMP_DOCS)

$(STAMP_DOCS): $(INSTALL_DEPS) | $(BIN)/python
	$(PIP) install --quiet -e '.[docs]'
	@touch $@ $(STAMP_RUN)

install: $(STAMP_RUN)

install-test: $(STAMP_TEST)

install-docs: $(STAMP_DOCS)

report: $(STAMP_RUN)
	$(BIN)/trainctl report

# The fast suite: everything but the tests marked e2e (pyproject.toml's markers), the
# long end-to-end runs of whole pipelines, which `make test-e2e` runs (.ci/run runs both).
test: $(STAMP_TEST)
	$(BIN)/python -m pytest -n auto --dist loadfile -m "not e2e"

test-e2e: $(STAMP_TEST)
	$(BIN)/python -m pytest -n auto --dist loadfile -m e2e tests

docs: $(STAMP_DOCS)
	$(BIN)/python -m sphinx -W --keep-going -b html docs docs/_build/html

# The wheel a course installs (docs/assignment): trainctl-toolbox, import name
# trainctl. DIST=DIR writes it elsewhere. Built in pip's isolated build
# environment, so it needs only the venv's pip.
DIST ?= dist
dist: | $(BIN)/python
	$(PIP) wheel --quiet --no-deps --wheel-dir $(DIST) .

lint: $(STAMP_TEST)
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/lint-imports

clean:
	rm -rf build dist docs/_build docs/auto_tutorials docs/api/generated docs/sg_execution_times.rst .pytest_cache .hypothesis .mypy_cache .ruff_cache .import_linter_cache
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -exec rm -rf {} +
