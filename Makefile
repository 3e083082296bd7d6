# unerode-cli: `make demo` and `make test` work on a fresh machine (they create .venv).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DEMO   := demo_out

.PHONY: venv install test test-all demo bench lint clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest

test-all: $(STAMP)
	$(BIN)/python -m pytest -m ''

demo: $(STAMP)
	mkdir -p $(DEMO)
	$(BIN)/unerode-cli info sample_dems/valley_utm32n_30m.tif
	$(BIN)/unerode-cli convert sample_dems/valley_utm32n_30m.tif $(DEMO)/valley.exr --overwrite
	$(BIN)/unerode-cli preview sample_dems/valley_utm32n_30m.tif $(DEMO)/valley.png --overwrite
	@echo "demo outputs in $(DEMO)/ (preview: $(DEMO)/valley.png)"

bench: $(STAMP)
	$(BIN)/python bench/run.py

lint: $(STAMP)
	$(BIN)/ruff check src tests bench
	$(BIN)/lint-imports

clean:
	rm -rf $(VENV) $(DEMO) build *.egg-info src/*.egg-info .pytest_cache .ruff_cache
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
