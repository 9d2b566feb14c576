# alcove: one entry point.
#   make up     set up .venv, build the web UI (if present), migrate, run `alcove up`
#   make test   set up .venv, build the web UI (if present), run the whole test suite (three phases, see test:)
#   make bench  run the benchmarks (bench/run.py)
# Everything is installed into .venv/ at the repository root, never the system Python.

SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
ALCOVE := $(VENV)/bin/alcove
STAMP := $(VENV)/.alcove-installed
PYTEST_ARGS ?=
BENCH_ARGS ?=

HAVE_FRONTEND := $(wildcard frontend/package.json)
HAVE_NPM := $(shell command -v npm 2>/dev/null)
FRONTEND_SOURCES := $(shell find frontend/src frontend/index.html frontend/vite.config.ts frontend/tsconfig.json -type f 2>/dev/null)
FRONTEND_OUT := backend/alcove/static/index.html

.PHONY: install frontend up test lint bench reproduce docs-images migrate worker clean-venv help
.DEFAULT_GOAL := help

help:
	@echo "make up     - install, build the UI, migrate and start alcove (API + worker) on the embedded default"
	@echo "make test   - install and run all tests (PostgreSQL and Redis must be running; see .ci/run)"
	@echo "make lint   - ruff (lint and format), mypy, no issue numbers or dates in the code, and the frontend's type check and linter"
	@echo "make bench  - run the benchmarks"

$(STAMP): pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PIP) install -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

ifneq ($(HAVE_FRONTEND),)
ifeq ($(HAVE_NPM),)
frontend:
	@echo "warning: npm not found; the web UI is not built (the API still works)" >&2
else
frontend/node_modules/.package-lock.json: frontend/package.json frontend/package-lock.json
	cd frontend && npm ci --no-audit --no-fund
	touch $@

$(FRONTEND_OUT): frontend/node_modules/.package-lock.json $(FRONTEND_SOURCES)
	cd frontend && npm run build

frontend: $(FRONTEND_OUT)
endif
else
frontend:
	@true
endif

migrate: install
	$(ALCOVE) db upgrade

up: install frontend
	$(ALCOVE) db upgrade
	$(ALCOVE) up

worker: install
	$(ALCOVE) worker

# The suite in three phases (tests/conftest.py marks the tests):
#   1. the tests not marked `serial`, on $(XDIST_WORKERS) pytest-xdist workers (a file's tests stay on one
#      worker, the listed ones are handed out one by one);
#   2. the `serial` tests not marked `alone`, also on $(XDIST_WORKERS) workers: they start or kill worker and
#      API processes, restart a Redis server of their own or drive the browser, each on a PostgreSQL schema,
#      Redis key prefix, data folder and ports of its own (under xdist a Redis database per worker);
#   3. the `alone` tests, one at a time with nothing beside them: they compare timings or hold a live
#      worker to a dead-worker threshold of a few seconds.
# Every phase always runs; make test fails if any fails or collects no tests (pytest's exit code 5).
XDIST_WORKERS ?= 2
test: install frontend
	@set +e; \
	$(PY) -m pytest tests -m "not serial" -n $(XDIST_WORKERS) --dist loadfile $(PYTEST_ARGS); rc1=$$?; \
	$(PY) -m pytest tests -m "serial and not alone" -n $(XDIST_WORKERS) --dist loadfile $(PYTEST_ARGS); rc2=$$?; \
	$(PY) -m pytest tests -m alone $(PYTEST_ARGS); rc3=$$?; \
	for rc in $$rc1 $$rc2 $$rc3; do \
	  if [ $$rc -eq 5 ]; then echo "pytest collected no tests in a phase: treated as a failure" >&2; fi; \
	done; \
	echo "make test: parallel phase exited with $$rc1, serial phase with $$rc2, alone phase with $$rc3"; \
	for rc in $$rc1 $$rc2; do if [ $$rc -ne 0 ]; then exit $$rc; fi; done; \
	exit $$rc3

# lint and types: what CI checks besides the tests (.ci/run runs it before make test)
PY_SOURCES := backend worker tests bench scripts migrations
lint: install
	$(VENV)/bin/ruff check $(PY_SOURCES)
	$(VENV)/bin/ruff format --check $(PY_SOURCES)
	$(VENV)/bin/mypy
	$(PY) scripts/check_history_refs.py
ifneq ($(HAVE_FRONTEND),)
ifneq ($(HAVE_NPM),)
	cd frontend && npm run typecheck && npm run lint
endif
endif

bench: install
	$(PY) -m bench.run $(BENCH_ARGS)

# the figures need matplotlib, the `reproduce` extra (not in the default install)
reproduce: install
	$(PIP) install -q -e '.[reproduce]'
	$(PY) scripts/reproduce.py $(REPRODUCE_ARGS)

# the docs' UI screenshots (docs/images/) come from the browser end-to-end test
docs-images: install frontend
	ALCOVE_DOCS_IMAGES=1 $(PY) -m pytest tests/e2e/test_browser.py -q

clean-venv:
	rm -rf $(VENV)
