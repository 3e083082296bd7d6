# unerode-cli: `make demo` and `make test` work on a fresh machine (they create .venv).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DEMO   := demo_out
SAMPLE := sample_dems/eroded_utm32n_30m.tif
# real chronologies (LR04 δ18O stack, Spratt & Lisiecki 2016 sea level), beside the checkout
DATA   ?= ../shared/data

.PHONY: venv install test test-all demo bench bench-memory lint clean docs gallery

venv: $(STAMP)

$(STAMP): pyproject.toml Makefile
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,mesh,xarray]'
	$(BIN)/python -m pip install --quiet 'fastscapelib>=0.3' \
		|| echo "fastscapelib unavailable: its anchor tests and bench comparisons are skipped"
	touch $(STAMP)

install: $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest

test-all: $(STAMP)
	$(BIN)/python -m pytest -m ''

demo: $(STAMP)
	mkdir -p $(DEMO)
	$(BIN)/unerode-cli info $(SAMPLE)
	$(BIN)/unerode-cli flow $(SAMPLE) $(DEMO)/discharge.tif --sea-level 0 --outlets S \
		--preview $(DEMO)/discharge.png --overwrite
	$(BIN)/unerode-cli unerode $(SAMPLE) $(DEMO)/valley_past.tif --process thermal,fluvial \
		--dt 500 --duration 20000 --sea-level 0 --outlets S --K 2e-5 --K-d 1 --k-th 0.002 \
		--change-map $(DEMO)/valley_past_change.tif --preview $(DEMO)/valley_past.png --overwrite
	$(BIN)/unerode-cli erode $(SAMPLE) $(DEMO)/valley_future.tif --process fluvial,thermal \
		--dt 500 --duration 20000 --sea-level 0 --outlets S --K 2e-5 --K-d 1 --k-th 0.002 \
		--change-map $(DEMO)/valley_future_change.tif --preview $(DEMO)/valley_future.png --overwrite
	$(BIN)/unerode-cli convert $(DEMO)/valley_past.tif $(DEMO)/valley_past.exr --overwrite
	@if [ -f $(DATA)/lr04/LR04stack.txt ]; then \
		$(BIN)/unerode-cli climate-run $(SAMPLE) $(DEMO)/valley_24ka.tif \
			--chronology $(DATA)/lr04/LR04stack.txt --sea-level $(DATA)/sealevel/spratt2016.txt \
			--from 0 --to 24 --dt 1000 --snapshots 12,20 --process thermal,fluvial \
			--K 2e-5 --downstream-below 100 --preview $(DEMO)/valley_24ka.png --overwrite; \
	else echo "no chronology in $(DATA): climate-run demo skipped (make demo DATA=...)"; fi
	@echo "demo outputs in $(DEMO)/ (previews: $(DEMO)/*.png)"

bench: $(STAMP)
	$(BIN)/python bench/run.py

# peak memory of whole commands at 8192² and 16 384² (about 45 minutes; bench/memory.md)
bench-memory: $(STAMP)
	$(BIN)/python bench/memory.py

# the documentation site (MkDocs Material): site/index.html, readable offline; warnings are errors
DOCS_STAMP := $(VENV)/.docs-installed

$(DOCS_STAMP): $(STAMP) pyproject.toml
	$(BIN)/python -m pip install --quiet -e '.[docs]'
	touch $(DOCS_STAMP)

# the gallery's pictures and page (docs/gallery/entries.yaml → docs/gallery/generated/)
gallery: $(STAMP)
	DATA=$(DATA) $(BIN)/python docs/gallery/build_gallery.py

docs: $(DOCS_STAMP) gallery
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

lint: $(STAMP)
	$(BIN)/ruff check src tests bench
	$(BIN)/lint-imports
	@dups=$$(find tests -name 'test_*.py' -printf '%f\n' | sort | uniq -d); \
	if [ -n "$$dups" ]; then echo "test modules that share a name (pytest imports them by it): $$dups"; exit 1; fi

clean:
	rm -rf $(VENV) $(DEMO) build *.egg-info src/*.egg-info .pytest_cache .ruff_cache
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
