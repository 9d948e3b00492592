# `make demo` and `make test` create .venv and install the project on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT := out
SOURCES := motionclean tests bench scripts

.PHONY: demo test bench lint clean-venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,dask]'
	touch $(STAMP)

$(VENV)/.bench: $(STAMP)
	$(BIN)/pip install --quiet -e '.[test,dask,bench]'
	touch $(VENV)/.bench

demo: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/motionclean info sample_data/131_02_noisy.bvh
	$(BIN)/motionclean clean sample_data/131_02_noisy.bvh -o $(OUT)/131_02_clean.bvh \
		--report $(OUT)/131_02_report.html
	$(BIN)/motionclean report sample_data/131_02_noisy.bvh $(OUT)/131_02_clean.bvh \
		--json $(OUT)/131_02_report.json > /dev/null
	@echo "wrote $(OUT)/131_02_clean.bvh, $(OUT)/131_02_report.html and $(OUT)/131_02_report.json"

test: lint
	$(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check $(SOURCES)
	$(BIN)/ruff format --check --quiet $(SOURCES)
	$(BIN)/mypy motionclean
	$(BIN)/lint-imports

bench: $(VENV)/.bench
	$(BIN)/python bench/run_all.py

clean-venv:
	rm -rf $(VENV)
