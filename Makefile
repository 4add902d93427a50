# shbake — two commands on a fresh machine with Python 3.11 and make:
#   make demo   # bake the sample maps, write previews and out/index.html (open it first)
#   make test   # run the test suite (CI runs this)
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
RUNTIME := $(VENV)/.installed-runtime
TESTENV := $(VENV)/.installed-test
SHARED ?= ../shared
OUT    ?= out
# Two cores: numba gets both, BLAS/OpenMP pools one each so they never fight (SPEC §6).
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1

ENGINES := tests/engines

.PHONY: demo test test-all test-setup chromium test-extremes bench bench-speed lint clean engines format-doc

# Two venv states: the runtime packages alone (make demo), then the test extras on top
# (make test: pytest, mitsuba, drjit, ducc0, hypothesis, ruff, ~1 GB). Either order works;
# a changed setup.cfg or lock reinstalls both. pip compiles the bytecode: with --no-compile
# under PYTHONDONTWRITEBYTECODE=1 every interpreter the tests start compiled what it imported
# (~200 s of CPU more in make test).
$(RUNTIME): setup.cfg pyproject.toml requirements.lock
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip==24.3.1
	$(BIN)/python -m pip install -q -c requirements.lock -e .
	touch $(RUNTIME)

$(TESTENV): $(RUNTIME)
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test]'
	touch $(TESTENV)

# The sample maps baked with the settings shbake's own advice names for them: --negative clamp
# (the negative-pixel warning's choice) and --lights auto --tol 0.02 (lights fitted with the
# SH: what lowers the error of the 9-coefficient export, project-env's advice), so the
# demo prints no advice it does not follow. out/index.html judges every error (overview).
demo: $(RUNTIME)
	@mkdir -p $(OUT)
	$(BIN)/shbake probe-fit data_samples/*.exr --out-dir $(OUT)/probes --jobs 2 --negative clamp \
	    --json > $(OUT)/probes.json
	@for m in data_samples/*.exr; do \
	  n=$$(basename $$m .exr); \
	  echo "== $$n" >&2; \
	  $(BIN)/shbake project-env $$m -o $(OUT)/$$n.h5 --lmax 8 --lights auto --tol 0.02 \
	      --negative clamp --exr-dir $(OUT)/$$n-maps --export threejs --report \
	      --json > $(OUT)/$$n.json || exit 1; \
	  $(BIN)/shbake preview $(OUT)/$$n.h5 --pass irradiance -o $(OUT)/$$n-irradiance.exr \
	      --diff --json > $(OUT)/$$n-irradiance.json || exit 1; \
	  $(BIN)/shbake preview $(OUT)/$$n.h5 --pass tangent -o $(OUT)/$$n-tangent.exr \
	      --diff --json > $(OUT)/$$n-tangent.json || exit 1; \
	  $(BIN)/shbake preview $(OUT)/probes/$$n.h5 --roughness 0.6 --f0 0.04 --size 128 \
	      -o $(OUT)/$$n-glossy.exr --diff --source $$m --json > $(OUT)/$$n-glossy.json || exit 1; \
	done
	$(BIN)/shbake tradeoff env_sh --map data_samples/sunset.exr --tol 0.02 \
	    -o $(OUT)/tradeoff-env_sh.png --csv $(OUT)/tradeoff-env_sh.csv
	$(BIN)/shbake overview $(OUT) -o $(OUT)/index.html --title "shbake demo: the six sample maps"
	@echo "demo: open $(OUT)/index.html (assets, previews and contact sheets in $(OUT)/)" >&2

# Real engine code for tests/format/exports/ and tests/system/test_engine_render.py, pinned by
# tests/engines/package-lock.json (npm ci runs no install script: puppeteer-core downloads no browser).
engines: $(ENGINES)/node_modules/.package-lock.json
$(ENGINES)/node_modules/.package-lock.json: $(ENGINES)/package.json $(ENGINES)/package-lock.json
	@if command -v npm >/dev/null 2>&1; then npm ci --prefix $(ENGINES) --no-audit --no-fund --ignore-scripts; \
	else echo "npm not found: the engine checks in tests/format/exports/ will skip" >&2; fi

# Debian's chromium for the rendered engine tests (tests/system/test_engine_render.py): installed when
# missing and run as root (CI); otherwise one line says what to install (those tests then skip).
chromium:
	@if [ -x /usr/bin/chromium ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  apt-get update -q && apt-get install -y -q --no-install-recommends chromium; \
	else echo "chromium not found: run 'apt-get install chromium' (as root) for the rendered engine tests" >&2; fi

# What the tests need, installed at once: pip keeps about one core busy, npm ci (and apt-get)
# the other (a sub-make, so that a plain `make test` runs them in parallel): 59 s instead of
# 71 s on a clean clone.
test-setup:
	@$(MAKE) --no-print-directory -j3 -Otarget $(TESTENV) engines chromium

# tests/warm_kernels.py first: the numba kernels compiled once, two halves in parallel, into the
# on-disk cache both pytest workers then read (from an empty cache each worker compiled them all).
test: test-setup
	$(BIN)/python -m tests.warm_kernels
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup

test-extremes: $(TESTENV)
	$(BIN)/python -m pytest -q -n 2 -m extremes tests/system/test_extremes.py

test-all: test-setup
	$(BIN)/python -m tests.warm_kernels
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup -m ''

bench: $(TESTENV)
	$(BIN)/python bench/run_all.py

# The speed tables of docs/BENCHMARKS.md alone (issue 15), rewritten in place.
bench-speed: $(TESTENV)
	$(BIN)/python bench/speed_tables.py

lint: $(TESTENV)
	$(BIN)/ruff check shbake cli tests bench

clean:
	rm -rf $(VENV) $(OUT) build *.egg-info

# docs/FORMAT.md: regenerate the per-kind tables from the registry (tests/format/test_registry.py checks)
format-doc: $(RUNTIME)
	$(BIN)/python -m shbake.format.registry docs/FORMAT.md
