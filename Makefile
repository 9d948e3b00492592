# `make demo` and `make test` create .venv and install the project on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT := out

.PHONY: demo test bench lint clean-venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

$(VENV)/.bench: $(STAMP)
	$(BIN)/pip install --quiet -e '.[test,bench]'
	touch $(VENV)/.bench

demo: $(STAMP)
	mkdir -p $(OUT)
	$(BIN)/motionclean info sample_data/131_02_noisy.bvh
	$(BIN)/motionclean convert sample_data/131_02_noisy.bvh $(OUT)/roundtrip.bvh
	cmp sample_data/131_02_noisy.bvh $(OUT)/roundtrip.bvh && echo "round trip: byte-identical"

test: $(STAMP)
	$(BIN)/ruff check motionclean tests bench scripts
	$(BIN)/python -m pytest

bench: $(VENV)/.bench
	$(BIN)/python bench/run_all.py

clean-venv:
	rm -rf $(VENV)
