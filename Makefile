# Every target creates .venv if missing and installs what it needs: a fresh machine needs nothing else.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python

.PHONY: run test test-slow lint docs bench bench-test mutate clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e '.[test]'
	touch $@

# The main job: the paper's experiments from models, quick settings (5-8 minutes on 2 cores on a
# fresh machine), written to reports/index.md with figures. The committed full report is reports/full/
# (`kruskal reproduce --out reports/full`).
run: $(VENV)/.installed
	$(VENV)/bin/kruskal reproduce --quick --out reports/

# pytest exits 5 when it collects no tests; that is not a failure of the suite. The suite runs on
# TEST_WORKERS processes (pytest-xdist), a whole test file per process (--dist loadfile: a module's
# fixtures are built once); TEST_WORKERS=0 runs it in this process.
TEST_WORKERS ?= 2
test: $(VENV)/.installed
	$(PY) -m pytest -q $(if $(filter 0,$(TEST_WORKERS)),,-n $(TEST_WORKERS) --dist loadfile); rc=$$?; if [ $$rc -eq 5 ]; then echo "no tests collected"; exit 0; fi; exit $$rc

test-slow: $(VENV)/.installed
	$(PY) -m pytest -q -m slow; rc=$$?; if [ $$rc -eq 5 ]; then exit 0; fi; exit $$rc

# ruff: pyflakes, pycodestyle, import order and complexity <= 15 outside the Numba kernels (pyproject.toml).
lint: $(VENV)/.installed
	$(VENV)/bin/ruff check .

# The API reference from the numpydoc docstrings (Sphinx, docs/api/conf.py), warnings as errors,
# written to docs/api/_build/html (about 25 s on 2 cores).
docs: $(VENV)/.installed
	$(PY) -m pip install --quiet -e '.[docs]'
	$(PY) -m sphinx -b html -q -W --keep-going docs/api docs/api/_build/html

bench: $(VENV)/.installed
	$(PY) -m benchmarks

# The benchmarks' own machinery (benchmarks/tests/: kept runs, resumption, summaries; the slow recovery
# protocol included). The product's suite (tests/) never imports benchmarks.
bench-test: $(VENV)/.installed
	$(PY) -m pytest -q -m '' benchmarks/tests

# Mutation testing of the core modules (tools/mutate.py, docs/testing.md): mutmut, one module at a
# time against the tests that cover it, two workers (MUTATE_JOBS=1 for one), the slow modules
# sampled (MUTATE_SAMPLE=1 for every mutant); `make mutate MODULES=grid` for one module.
mutate: $(VENV)/.installed
	MUTATE_JOBS=$${MUTATE_JOBS:-2} $(PY) tools/mutate.py $(MODULES)

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache mutants
