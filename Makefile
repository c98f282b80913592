# surfhap: two commands set everything up on a fresh machine with python3 (3.11+) and make.
#   make demo   render every built-in material on the simulated display, write demo/report.html
#   make test   install, check the import layers (lint-imports), run the whole test suite
#   make bench  run the performance benchmarks (one JSON line each)
#   make soak   nightly-style: the whole-process safety property tests (texture engine, force
#               loop, study runner) with SOAK_EXAMPLES (default 300000) freshly random sequences
#               for the engine (1/5 for the force loop, 1/100 for the study runner) instead of
#               the fixed ones of `make test`
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

# Debian packages the tests need (browser, audio server, ...); installed with apt-get
# when missing. Keep this list the only place system packages are named.
SYSTEM_PACKAGES := chromium jackd2 libportaudio2 liblo-tools

.PHONY: install system-deps demo test bench soak builtins calibrate-builtins clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e ".[dev,live,lsl,dask,daq]"
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
	$(VENV)/bin/surfhap demo --out demo --overwrite

# the layer contracts of pyproject.toml ([tool.importlinter], drawn in docs/architecture.md)
# fail the build before any test runs. numba's cache is cleared first, as on CI's clean clone: a
# kernel cached in one module keeps an old copy of a changed callee in another, so an edited
# kernel could pass on its old code. PYTHONFAULTHANDLER: a fatal signal in the test process (a
# native crash, also at its exit, after pytest has restored its own handler) prints every
# thread's Python stack
# numba's cache: a kernel cached in one module keeps an old copy of a changed callee in another
CLEAR_NUMBA_CACHE = find src -name '*.nbi' -delete -o -name '*.nbc' -delete

test: system-deps $(STAMP)
	$(VENV)/bin/lint-imports --no-cache
	$(CLEAR_NUMBA_CACHE)
	PYTHONFAULTHANDLER=1 $(PY) -m pytest

# the whole-process safety property tests with many more, freshly random, sequences
SOAK_EXAMPLES ?= 300000
soak: $(STAMP)
	SURFHAP_SAFETY_SOAK=1 SURFHAP_SAFETY_EXAMPLES=$(SOAK_EXAMPLES) $(PY) -m pytest -q -p no:cacheprovider tests/test_live_engine_property.py tests/test_ff_loop_property.py tests/test_lab_session_property.py

# one core: the targets are per-core figures. Every benchmark runs; stdout holds only their
# JSON lines (progress goes to stderr); the target fails when any figure missed its target.
bench: $(STAMP)
	@status=0; for b in benchmarks/bench_*.py; do \
	  OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 $(PY) $$b || { status=1; echo "bench: $$b missed a target or failed" >&2; }; \
	done; exit $$status

# Refit the built-in textures from the real recordings (commands recorded in each file's provenance)
HAPMAT ?= ../shared/data/hapmat-imu
BUILTIN := src/surfhap/models/builtin
builtins: $(STAMP)
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/leather_1.csv --into $(BUILTIN)/leather.json --order 37 --note "HapMat Leather 1 (unspecified leather) as leather; AR order of Otake et al. 2021 Table II (leather 37)"
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/fabric_1.csv --into $(BUILTIN)/denim.json --order 19 --note "HapMat Fabric 1 (unspecified fabric) as denim, a fabric; AR order of Otake et al. 2021 Table II (denim 19)"
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/paper_1.csv --into $(BUILTIN)/drawing-paper.json --order 32 --note "HapMat Paper 1 (unspecified paper) as drawing paper; AR order of Otake et al. 2021 Table II (drawing paper 32)"
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/wood_1.csv --into $(BUILTIN)/wood.json --note "HapMat Wood 1 (unspecified wood) as wood; Otake et al. 2021 give no order for wood, so AIC chooses it"
	$(VENV)/bin/surfhap fit imu $(HAPMAT)/wood_1.csv --into $(BUILTIN)/cork.json --note "HapMat Wood 1 as cork: no openly licensed cork recording exists; cork is the bark of the cork oak, and wood is the nearest HapMat material; AIC chooses the order"
	$(MAKE) calibrate-builtins

# Texture strength of the built-ins: friction:texture voltage ratios of Otake et al. 2022 (003),
# Sec. IV-D. A separate step after the refit (the refit test compares only the AR models).
RATIO_REF := Otake et al. 2022 (shared/papers/003_1a15d13042f9a763.txt), Sec. IV-D: approximate friction:texture voltage ratios (10:3), (10:6), (10:6), (10:4) for leather, cork, denim, wood
calibrate-builtins: $(STAMP)
	$(VENV)/bin/surfhap calibrate-texture $(BUILTIN)/leather.json --ratio 0.3 --reference "$(RATIO_REF); leather 10:3"
	$(VENV)/bin/surfhap calibrate-texture $(BUILTIN)/cork.json --ratio 0.6 --reference "$(RATIO_REF); cork 10:6" --note "texture of the wood recording (nearest available), at cork's ratio"
	$(VENV)/bin/surfhap calibrate-texture $(BUILTIN)/denim.json --ratio 0.6 --reference "$(RATIO_REF); denim 10:6"
	$(VENV)/bin/surfhap calibrate-texture $(BUILTIN)/wood.json --ratio 0.4 --reference "$(RATIO_REF); wood 10:4"
	$(VENV)/bin/surfhap calibrate-texture $(BUILTIN)/drawing-paper.json --ratio 0.4 --reference "$(RATIO_REF); drawing paper: none published, wood's 10:4 used" --note "003 Sec. II replaced the drawing paper (highly smooth, minimal texture) by wood as its smooth material; 001 gives no ratio"

clean:
	rm -rf $(VENV) demo build *.egg-info src/*.egg-info .pytest_cache .import_linter_cache
	$(CLEAR_NUMBA_CACHE)
