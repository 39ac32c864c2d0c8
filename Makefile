# Quick start targets. `make demo` and `make test` work on a fresh machine with python3 >= 3.11.
VENV ?= .venv
PY := $(VENV)/bin/python
BIN := $(VENV)/bin

.PHONY: setup demo test test-slow lint bench clean

setup: $(VENV)/.installed

# torch first (then the dev, train, ray and baselines extras), pinned to the CPU wheel on disk, so nothing pulls a multi-GB CUDA build
$(VENV)/.installed: pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q torch==2.13.0
	$(PY) -m pip install -q -e '.[dev,train,ray,baselines]'
	touch $@

demo: setup
	$(BIN)/lamde-mission plan examples/maps/small-demo.json -o mission.plan --plot mission.png

test: setup
	$(BIN)/ruff check .
	$(BIN)/lint-imports
	$(PY) -m pytest

test-slow: setup
	$(PY) -m pytest -m slow

lint: setup
	$(BIN)/ruff check .
	$(BIN)/lint-imports

bench: setup
	$(PY) benchmarks/bench_evaluate.py
	$(PY) benchmarks/bench_plan.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache
