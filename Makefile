# fcol — the two commands of the README are `make demo` and `make test`.
# Both set up everything they need on a fresh machine: a virtualenv in .venv,
# maturin, the test dependencies, and a release build of the extension.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
STAMP  := $(VENV)/.deps-stamp
export VIRTUAL_ENV := $(abspath $(VENV))
export PATH := $(abspath $(VENV))/bin:$(PATH)

.PHONY: all demo test build build-dev cargo-test pytest bench stubtest fmt lint clean

all: build

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(PY)
	$(PIP) install --quiet "maturin>=1.9.4,<2" "numpy>=1.24" \
	    "pytest>=8" "hypothesis>=6" "scikit-image>=0.22" "trimesh>=4" \
	    "embreex>=2.17" "openimageio>=2.5" "matplotlib>=3.8" "scipy>=1.11" "mypy>=1.10" "mpmath>=1.3" \
	    "threadpoolctl>=3.1"
	touch $(STAMP)

# Release build (lto, codegen-units = 1) installed into .venv, compiled for
# this machine's processor (its AVX2, FMA, AVX-512 where it has them), as a
# build from source for local use should be: the outputs are the same bit
# for bit, 5-10 % sooner. PORTABLE=1 builds for the x86-64 baseline (what a
# wheel for other machines needs: `maturin build --release`).
ifeq ($(PORTABLE),)
CPU_FLAGS := -C target-cpu=native
endif
build: $(STAMP)
	RUSTFLAGS="$(strip $(RUSTFLAGS) $(CPU_FLAGS))" $(VENV)/bin/maturin develop --release --quiet

# Faster debug-ish build for iterating (opt-level 1, dependencies at 3).
build-dev: $(STAMP)
	$(VENV)/bin/maturin develop --quiet

cargo-test:
	cargo test --quiet

pytest: $(STAMP)
	$(PY) -m pytest -q

stubtest: $(STAMP)
	$(PY) -m mypy.stubtest fcol._fcol --allowlist tests/stubtest-allowlist.txt

test: build cargo-test pytest stubtest

demo: build
	$(PY) -m fcol.demo --out gallery

bench: build
	$(PY) -m fcol.bench --out bench-out

fmt:
	cargo fmt --all

lint:
	cargo fmt --all -- --check
	cargo clippy --all-targets --features python -- -D warnings

clean:
	rm -rf target $(VENV) gallery bench-out
