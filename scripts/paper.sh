#!/usr/bin/env bash
# Builds flexclear and reproduces the paper study into ${1:-flexclear-report}/ (report.md + PNGs).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. .venv/bin/activate
flexclear paper --out "${1:-flexclear-report}"
