#!/usr/bin/env bash
# Creates .venv (if missing) with the build and test tools, builds flexclear in release mode (with
# profile-guided optimization, below) as the abi3 wheel users install (target/dist/flexclear-*.whl)
# and installs that wheel into .venv
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
# Profile-guided optimization (PGO): the extension is first built instrumented and run on
# scripts/pgo_train.py (the paths users run most, a few seconds), then built again with that
# profile; the flags go to the flexclear crate alone (maturin passes what follows `--` to rustc
# for it), so its dependencies are compiled once and shared with the plain builds of cargo test.
# About 5 % fewer ns a step on the slider-crank; no result changes (the golden hashes are the
# same). Needs llvm-profdata of rustc's own LLVM (rustup component llvm-tools); without it, or
# with FLEXCLEAR_PGO=0, the wheel is built once without a profile.
profdata=""
if [ "${FLEXCLEAR_PGO:-1}" != 0 ]; then
  timeout 300 rustup component add llvm-tools >/dev/null 2>&1 || true
  tool="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin/llvm-profdata"
  if [ -x "$tool" ]; then
    root="$PWD"
    pgo="$root/target/pgo"
    rm -rf "$pgo"
    mkdir -p "$pgo/raw"
    maturin build --release -q --out "$pgo/wheel" -- "-Cprofile-generate=$pgo/raw"
    python -m pip install -q --force-reinstall --no-deps "$pgo"/wheel/flexclear-*.whl
    # run from outside the repository: flexclear comes from the instrumented wheel
    (cd "$pgo" && python "$root/scripts/pgo_train.py")
    "$tool" merge -o "$pgo/flexclear.profdata" "$pgo/raw"
    profdata="$pgo/flexclear.profdata"
  else
    echo "setup: no llvm-profdata (rustup component add llvm-tools): the wheel is built without PGO" >&2
  fi
fi
if [ -n "$profdata" ]; then
  maturin build --release -q --out target/dist -- "-Cprofile-use=$profdata"
else
  maturin build --release -q --out target/dist
fi
# The runtime dependencies are installed above; --no-deps keeps pip offline here. A stale
# editable install (maturin develop) is replaced.
python -m pip install -q --force-reinstall --no-deps target/dist/flexclear-*.whl
