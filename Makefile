# surfhap: two commands set everything up on a fresh machine with python3 (3.11+) and make.
#   make demo   render every built-in material on the simulated display, write demo/report.html
#   make test   install and run the whole test suite
#   make bench  run the performance benchmarks (one JSON line each)
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

# Debian packages the tests need (browser, audio server, ...); installed with apt-get
# when missing. Keep this list the only place system packages are named.
SYSTEM_PACKAGES :=

.PHONY: install system-deps demo test bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e ".[dev,live]"
	touch $(STAMP)

system-deps:
	@missing=""; for p in $(SYSTEM_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing system packages:$$missing"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq --no-install-recommends $$missing >/dev/null; \
	fi

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/surfhap demo --out demo

test: system-deps $(STAMP)
	$(PY) -m pytest

bench: $(STAMP)
	@for b in benchmarks/bench_*.py; do $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) demo build *.egg-info src/*.egg-info .pytest_cache
