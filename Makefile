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
SYSTEM_PACKAGES := chromium jackd2 libportaudio2

.PHONY: install system-deps demo test bench builtins clean

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

# one core: the targets are per-core figures
bench: $(STAMP)
	@for b in benchmarks/bench_*.py; do OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 $(PY) $$b || exit 1; done

# Refit the built-in textures from the real recordings (commands recorded in each file's provenance)
HAPMAT ?= ../shared/data/hapmat-imu
BUILTIN := src/surfhap/models/builtin
builtins: $(STAMP)
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/leather_1.csv --into $(BUILTIN)/leather.json --order 37 --note "HapMat Leather 1 (unspecified leather) as leather; AR order of Otake et al. 2021 Table II (leather 37)"
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/fabric_1.csv --into $(BUILTIN)/denim.json --order 19 --note "HapMat Fabric 1 (unspecified fabric) as denim, a fabric; AR order of Otake et al. 2021 Table II (denim 19)"
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/paper_1.csv --into $(BUILTIN)/drawing-paper.json --order 32 --note "HapMat Paper 1 (unspecified paper) as drawing paper; AR order of Otake et al. 2021 Table II (drawing paper 32)"
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/wood_1.csv --into $(BUILTIN)/wood.json --note "HapMat Wood 1 (unspecified wood) as wood; Otake et al. 2021 give no order for wood, so AIC chooses it"

clean:
	rm -rf $(VENV) demo build *.egg-info src/*.egg-info .pytest_cache
