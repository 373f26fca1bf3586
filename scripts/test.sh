#!/usr/bin/env bash
# Builds flexclear once (release, the abi3 wheel in target/dist, installed into .venv) and runs
# every check: rustfmt, clippy, rustdoc (no broken links), the Rust tests, ruff, stubtest (the stubs
# python/flexclear/_core.pyi against the compiled module), pytest against the installed wheel,
# the speed gate (benches/gate.py --quick: this tree against benches/gate_base) and a fresh-venv
# check of the wheel (scripts/fresh_venv_check.sh: README examples and CLI quick paths). Prints
# the time of each part at the end.
set -euo pipefail
cd "$(dirname "$0")/.."
times=()
step() {
  local name=$1
  shift
  echo "== $name"
  local t0=$SECONDS
  "$@"
  times+=("$(printf '%-22s %5d s' "$name" $((SECONDS - t0)))")
}
summary() {
  echo "== times"
  printf '%s\n' "${times[@]}"
  printf '%-22s %5d s\n' total "$SECONDS"
}
trap summary EXIT
installed() {
  # pytest runs from the repository root: flexclear must come from .venv's site-packages.
  python - <<'PY'
import sysconfig
from pathlib import Path

import flexclear
import flexclear._core

site = {Path(sysconfig.get_paths()[k]).resolve() for k in ("purelib", "platlib")}
for mod in (flexclear, flexclear._core):
    f = Path(mod.__file__).resolve()
    if not any(s in f.parents for s in site):
        raise SystemExit(f"{mod.__name__} is imported from {f}, not from the installed wheel in {site}")
print(f"flexclear from {Path(flexclear.__file__).parent}")
PY
}
cargo_doc() {
  # the API docs and the developers' (private items too) without a broken or private link
  RUSTDOCFLAGS="-D warnings" cargo doc --no-deps -q --all-features &&
    RUSTDOCFLAGS="-D warnings" cargo doc --no-deps -q --all-features --document-private-items
}
ruff_all() { ruff check python tests benches scripts && ruff format --check python tests benches scripts; }

step "setup (venv, wheel)" bash scripts/setup.sh
. .venv/bin/activate
step "cargo fmt --check"   cargo fmt --check
step "cargo clippy"        cargo clippy --all-targets --all-features -q -- -D warnings
step "cargo doc"           cargo_doc
step "cargo test"          cargo test --release -q
step "ruff"                ruff_all
step "stubtest"            env MYPY_CACHE_DIR=target/mypy_cache python -m mypy.stubtest flexclear._core \
                             --allowlist scripts/stubtest_allowlist.txt
step "installed package"   installed
step "pytest"              python -m pytest -q tests
step "bench gate --quick"  python benches/gate.py --quick
step "fresh venv"          bash scripts/fresh_venv_check.sh
