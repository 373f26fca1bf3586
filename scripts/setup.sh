#!/usr/bin/env bash
# Creates .venv (if missing) with the build and test tools, builds flexclear once in release mode
# as the abi3 wheel users install (target/dist/flexclear-*.whl) and installs that wheel into .venv
# (not an editable install: the tests import what `pip install` gives users). Idempotent; used by
# scripts/test.sh and scripts/paper.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v cargo >/dev/null || { echo "cargo not found: install Rust (https://rustup.rs)" >&2; exit 1; }
rustup component add rustfmt clippy >/dev/null 2>&1 || true
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
. .venv/bin/activate
python -m pip install -q --upgrade pip
python -m pip install -q "maturin>=1.7,<2" "numpy>=1.22" "matplotlib>=3.5" "tqdm>=4.60" "pytest>=8" "hypothesis>=6.100" "ruff>=0.6" "mypy>=1.10" \
  "pandas>=1.5" "pyarrow>=12" "scipy>=1.9" "dask[distributed]>=2023.1" "tomli>=2; python_version < '3.11'"
rm -rf target/dist
maturin build --release -q --out target/dist
# The runtime dependencies are installed above; --no-deps keeps pip offline here. A stale
# editable install (maturin develop) is replaced.
python -m pip install -q --force-reinstall --no-deps target/dist/flexclear-*.whl
