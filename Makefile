# physid: two commands on a fresh machine (Python >= 3.10 and pip): `make demo` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
OUT    ?= demo-out
ARGS   ?=

.PHONY: demo test bench lint clean venv fuzz

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# Stamp files record which extras were installed, so re-running is cheap.
$(VENV)/.core: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.full: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[dev,peers,dask,parquet,zoo]"
	touch $@ $(VENV)/.core

demo: $(VENV)/.core
	$(BIN)/physid demo --out $(OUT) $(ARGS)

test: $(VENV)/.full
	$(BIN)/python tools/ensure_chromium.py || true
	$(BIN)/lint-imports --no-cache
	MPLBACKEND=Agg $(BIN)/python -m pytest $(ARGS)

# Property tests of every loader and the expression parser at >= 20000 examples each (slow).
fuzz: $(VENV)/.full
	MPLBACKEND=Agg $(BIN)/python -m pytest tests/fuzz -p no:randomly --hypothesis-profile=fuzz \
		--hypothesis-show-statistics -q $(ARGS)

bench: $(VENV)/.full
	MPLBACKEND=Agg $(BIN)/python benchmarks/run.py $(ARGS)

lint: $(VENV)/.full
	$(BIN)/ruff check src tests benchmarks examples tools
	$(BIN)/ruff format --check src tests benchmarks examples tools

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .physid-cache build src/*.egg-info
