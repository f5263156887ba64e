# vfmodel: `make demo` and `make test` are the two set-up commands (CONTRACT section 1).
PYTHON ?= python3
# one BLAS thread per process: the test workers and benchmarks run side by side on 2 cores
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1
VENV   := .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
DEMO_OUT ?= demo-out

.PHONY: demo test test-slow lint typecheck pytest ngspice chromium clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip

$(VENV)/.installed: pyproject.toml | $(PY)
	$(PIP) install -q -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(PY)
	$(PIP) install -q -e '.[test]'
	touch $@ $(VENV)/.installed

ngspice:
	@command -v ngspice >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = "0" ]; then \
	    echo "ngspice missing: installing the Debian package"; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq ngspice) >/dev/null; \
	  else \
	    echo "ngspice is needed by the tests: install it, e.g. 'sudo apt-get install ngspice'"; exit 1; \
	  fi; }
	@ngspice --version | head -n 2 | tail -n 1

# the browser test of the HTML reports drives headless Chromium (Debian: chromium)
chromium:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = "0" ]; then \
	    echo "chromium missing: installing the Debian package"; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium) >/dev/null; \
	  else \
	    echo "chromium is needed by the tests: install it, e.g. 'sudo apt-get install chromium'"; exit 1; \
	  fi; }
	@chromium --version

demo: $(VENV)/.installed
	$(PY) scripts/demo.py --out $(DEMO_OUT)

lint: $(VENV)/.installed-test
	$(VENV)/bin/ruff check vfmodel tests scripts benches

typecheck: $(VENV)/.installed-test
	$(VENV)/bin/mypy

pytest: $(VENV)/.installed-test ngspice chromium
	$(VENV)/bin/pytest -q -n 2 -m "not slow" --durations=15

# long acceptance runs (minutes each); not part of `make test`
test-slow: $(VENV)/.installed-test ngspice
	$(VENV)/bin/pytest -q -n 2 -m slow --durations=15

test: lint typecheck pytest

clean:
	rm -rf $(VENV) $(DEMO_OUT) .pytest_cache .mypy_cache .ruff_cache
