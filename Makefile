# Quick start targets. `make demo` and `make test` work on a fresh machine with python3 >= 3.11.
VENV ?= .venv
PY := $(VENV)/bin/python
BIN := $(VENV)/bin
# editable installs through a plain path entry (one .pth line) rather than setuptools' import
# hook: the interpreter starts ~15 ms sooner, so a Ctrl-C right after launch reaches our handler.
# setuptools calls this mode transitional (it warns); where it is gone, each install below
# falls back to the default mode
EDITABLE := --config-settings editable_mode=compat
# MkDocs' banner about its successor, printed on every build
export NO_MKDOCS_2_WARNING := 1

.PHONY: setup demo test test-slow lint docs docs-build docs-update figures bench clean

# everything: what `make test` needs
setup: $(VENV)/.installed

$(PY):
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

# what planning needs and nothing else (no torch, no extras), so a plain package index never
# pulls a multi-GB CUDA build for the demo
$(VENV)/.planning: pyproject.toml | $(PY)
	$(PY) -m pip install -q -e . $(EDITABLE) || $(PY) -m pip install -q -e .
	$(PY) -m planner_core.pipeline.warmup
	touch $@

# planning + the manual's tools (mkdocs, Material, mkdocstrings): `make docs`
$(VENV)/.docs: pyproject.toml | $(PY)
	$(PY) -m pip install -q -e '.[docs]' $(EDITABLE) || $(PY) -m pip install -q -e '.[docs]'
	touch $(VENV)/.planning $@

# torch first, pinned to the CPU wheel on disk, then every extra: the tests, training, Ray, the
# benchmark's peers and the manual
$(VENV)/.installed: pyproject.toml | $(PY)
	$(PY) -m pip install -q torch==2.13.0
	$(PY) -m pip install -q -e '.[dev,train,ray,baselines,docs]' $(EDITABLE) || $(PY) -m pip install -q -e '.[dev,train,ray,baselines,docs]'
	$(PY) -m planner_core.pipeline.warmup
	touch $(VENV)/.planning $(VENV)/.docs $@

demo: $(VENV)/.planning
	$(BIN)/lamde-mission plan examples/maps/small-demo.json -o mission.plan --plot mission.png

# ruff, the import contracts, the manual (strict: a broken link or reference fails) and every
# test not marked slow; prints how long it took. The docs test reads the site built here.
test: setup
	@start=$$(date +%s); \
	$(BIN)/ruff check . && $(BIN)/lint-imports && $(BIN)/mkdocs build --strict -q && \
	LAMDE_DOCS_SITE=$(CURDIR)/build/site $(PY) -m pytest; \
	rc=$$?; echo "make test: $$(( $$(date +%s) - start )) s (exit status $$rc)"; exit $$rc

test-slow: setup
	$(PY) -m pytest -m slow

lint: setup
	$(BIN)/ruff check .
	$(BIN)/lint-imports

# the manual at http://127.0.0.1:8000, rebuilt on every change
docs: $(VENV)/.docs
	$(BIN)/mkdocs serve

# the manual into build/site, warnings as errors
docs-build: $(VENV)/.docs
	$(BIN)/mkdocs build --strict

# the generated copies committed beside the sources: README's defaults table and the manual's
# CLI and defaults reference pages (tests fail while they are stale)
docs-update: setup
	$(PY) -m planner_core.defaults README.md
	$(PY) docs/hooks.py --update

# every figure the manual and the README show: the benchmark figures redrawn from the runs stored
# under docs/ (no benchmark is re-run; a report whose runs are not stored is named, its stored
# studies redrawn), then the gallery (docs/gallery/, the README's picture) planned and drawn anew
figures: setup
	$(PY) docs/make_figures.py
	$(PY) docs/make_gallery.py

bench: setup
	$(PY) benchmarks/bench_evaluate.py
	$(PY) benchmarks/bench_plan.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache build/site
