#!/usr/bin/env bash
# Builds flexclear and runs every check: rustfmt, clippy, the Rust tests, ruff, stubtest (the
# stubs python/flexclear/_core.pyi against the compiled module) and pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. .venv/bin/activate
echo "== cargo fmt --check";  cargo fmt --check
echo "== cargo clippy";       cargo clippy --all-targets --all-features -q -- -D warnings
echo "== cargo test";         cargo test --release -q
echo "== ruff";               ruff check python tests benches && ruff format --check python tests benches
echo "== stubtest";           MYPY_CACHE_DIR=target/mypy_cache python -m mypy.stubtest flexclear._core \
                                --allowlist scripts/stubtest_allowlist.txt
echo "== pytest";             python -m pytest -q tests
