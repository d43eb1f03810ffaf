PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo test bench accuracy clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $@ $(VENV)/.installed

# make demo: the core and the parquet extra (pandas, pyarrow), which linkdyn sweep needs
$(VENV)/.installed-demo: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[parquet]"
	touch $@ $(VENV)/.installed

$(VENV)/.installed-fast: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[fast,parquet]"
	touch $@ $(VENV)/.installed

# make bench: numba, and sympy for bench_inverse.py's sympy.mechanics baseline
$(VENV)/.installed-bench: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[fast,parquet,bench]"
	touch $@ $(VENV)/.installed-fast $(VENV)/.installed

demo: $(VENV)/.installed-demo
	$(BIN)/linkdyn example hoeken > hoeken.toml
	$(BIN)/linkdyn analyze hoeken.toml -o out/hoeken --report
	@echo "Results: out/hoeken/results.csv, out/hoeken/summary.json, plots out/hoeken/plot_*.png and the report out/hoeken/report.html"
	@echo "Run linkdyn from the venv: . $(BIN)/activate (or $(BIN)/linkdyn ...)"

# every core (pytest-xdist); the compiled-backend tests share one worker (tests/conftest.py)
test: $(VENV)/.installed-test
	$(BIN)/python -m pytest -q -n auto --dist loadgroup

# the scripts' own reference checks (pytest -m bench, tests/test_benchmarks.py), then the timings
bench: $(VENV)/.installed-bench $(VENV)/.installed-test
	$(BIN)/python -m pytest -q -m bench tests/test_benchmarks.py tests/test_performance_page.py
	$(BIN)/python benchmarks/bench_hoeken.py
	$(BIN)/python benchmarks/bench_kernels.py
	$(BIN)/python benchmarks/bench_ceiling.py
	$(BIN)/python benchmarks/bench_inverse.py
	$(BIN)/python benchmarks/bench_sweep.py
	$(BIN)/python benchmarks/bench_simulate.py
	$(BIN)/python benchmarks/bench_compile.py
	$(BIN)/python benchmarks/bench_friction.py
	$(BIN)/python benchmarks/bench_modes.py
	$(BIN)/python benchmarks/bench_page.py
	$(BIN)/python benchmarks/bench_spatial.py

accuracy: $(VENV)/.installed-fast
	$(BIN)/python benchmarks/accuracy.py

clean:
	rm -rf $(VENV) out hoeken.toml
