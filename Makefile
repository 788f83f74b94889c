# Argand: make setup | make run | make test | make bench
# Everything is installed into .venv from PyPI (and Debian packages where
# noted), so a fresh Debian machine with Python 3.11 and a C++ compiler works.

VENV    ?= .venv
PY      := $(VENV)/bin/python
PIP     := $(PY) -m pip
STAMP   := $(VENV)/.argand-deps
SOURCES := $(shell find core python api worker -type f \( -name '*.cpp' -o -name '*.h' -o -name '*.py' -o -name '*.pyi' -o -name 'CMakeLists.txt' \) 2>/dev/null) CMakeLists.txt pyproject.toml

.PHONY: setup build run test test-cpp test-py bench bench-smoke clean

setup: $(VENV)/.argand-built

# Python environment and the build requirements (we build without isolation
# so that the C++ build directory is reused between builds).
$(STAMP): pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q "scikit-build-core>=0.10" "pybind11>=2.12" cmake ninja
	$(PIP) install -q numpy "python-flint>=0.6" "typer>=0.12" "rich>=13" "pydantic>=2.5" "pyyaml>=6" "OpenImageIO>=2.5" "pytest>=8" "mpmath>=1.3" "matplotlib>=3.8"
	touch $@

# The package itself (C++ core + Python), rebuilt when a source changes.
$(VENV)/.argand-built: $(STAMP) $(SOURCES)
	$(PIP) install -q --no-build-isolation --no-deps .
	touch $@

build: $(VENV)/.argand-built

# The main job. (The render farm arrives with issue 4; until then `make run`
# shows the verified root finder at work on a few classic cases.)
run: setup
	$(VENV)/bin/argand roots 1 0 0 0 1
	$(VENV)/bin/argand roots -- -1 0 1 --method paper
	$(VENV)/bin/argand roots 1 -4 6 -4 1

# C++ unit tests of the arithmetic, with the CMake that setup installed.
test-cpp: $(STAMP)
	$(VENV)/bin/cmake -S . -B build/cpp -DCMAKE_BUILD_TYPE=Release >/dev/null
	$(VENV)/bin/cmake --build build/cpp -j2 >/dev/null
	$(VENV)/bin/ctest --test-dir build/cpp --output-on-failure

test-py: setup
	$(VENV)/bin/pytest

test: test-cpp test-py

bench: setup
	$(VENV)/bin/argand bench roots

bench-smoke: setup
	$(VENV)/bin/argand bench roots --smoke --out build/bench-smoke

clean:
	rm -rf build dist $(VENV)
