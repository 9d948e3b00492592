# `make demo` and `make test` create .venv and install the project on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT := out
SOURCES := motionclean tests bench scripts blender
# Blender as a Python module (bpy) pins Python 3.11 and numpy < 2: its own environments.
PYTHON_BLENDER ?= python3.11
BPY_VERSION := 5.0.1
BPY45_VERSION := 4.5.15
BLENDER_VENV := .venv-blender
BLENDER_STAMP := $(BLENDER_VENV)/.installed
BLENDER45_VENV := .venv-blender45
BLENDER45_STAMP := $(BLENDER45_VENV)/.installed

.PHONY: demo test test-blender45 blender bench lint clean-venv bytecode

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test,dask]'
	touch $(STAMP)

# The package's bytecode, written once: where PYTHONDONTWRITEBYTECODE is set, every
# process (each `motionclean` command, each test's subprocess) would compile it again.
bytecode: $(STAMP)
	$(BIN)/python -m compileall -q motionclean

$(BLENDER_STAMP): pyproject.toml
	$(PYTHON_BLENDER) -m venv $(BLENDER_VENV)
	$(BLENDER_VENV)/bin/pip install --quiet --upgrade pip
	$(BLENDER_VENV)/bin/pip install --quiet bpy==$(BPY_VERSION) -e .
	touch $(BLENDER_STAMP)

$(BLENDER45_STAMP): pyproject.toml
	$(PYTHON_BLENDER) -m venv $(BLENDER45_VENV)
	$(BLENDER45_VENV)/bin/pip install --quiet --upgrade pip
	$(BLENDER45_VENV)/bin/pip install --quiet bpy==$(BPY45_VERSION) -e .
	touch $(BLENDER45_STAMP)

$(VENV)/.bench: $(STAMP)
	$(BIN)/pip install --quiet -e '.[test,dask,bench]'
	touch $(VENV)/.bench

demo: $(STAMP) bytecode
	mkdir -p $(OUT)
	$(BIN)/motionclean info sample_data/131_02_noisy.bvh
	$(BIN)/motionclean clean sample_data/131_02_noisy.bvh -o $(OUT)/131_02_clean.bvh \
		--report $(OUT)/131_02_report.html --report $(OUT)/131_02_report.json
	@echo "wrote $(OUT)/131_02_clean.bvh, $(OUT)/131_02_report.html and $(OUT)/131_02_report.json"

# One test process per core, each taking whole files (their shared fixtures made once).
# Where PYTHONDONTWRITEBYTECODE is set, each process would rewrite the test modules'
# assertions again on every run (about 10 s each); pytest keeps them in tests/__pycache__.
test: lint bytecode $(BLENDER_STAMP)
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -n auto --dist loadfile

# The extension's operator checks in Blender 4.5 LTS (bpy 4.5) instead of 5.0.
test-blender45: $(STAMP) bytecode $(BLENDER45_STAMP)
	MOTIONCLEAN_BLENDER_PYTHON=$(BLENDER45_VENV)/bin/python MOTIONCLEAN_BLENDER_OPERATOR_ONLY=1 \
		$(BIN)/python -m pytest tests/blender

# The Blender extension: dist/motionclean-blender-VERSION.zip (drag it into Blender).
blender: $(STAMP)
	$(BIN)/python scripts/build_blender_extension.py dist

lint: $(STAMP)
	$(BIN)/ruff check $(SOURCES)
	$(BIN)/ruff format --check --quiet $(SOURCES)
	$(BIN)/mypy motionclean
	$(BIN)/lint-imports

bench: $(VENV)/.bench bytecode
	$(BIN)/python bench/run_all.py

clean-venv:
	rm -rf $(VENV) $(BLENDER_VENV) $(BLENDER45_VENV)
