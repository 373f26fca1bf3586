#!/usr/bin/env bash
# Fresh-venv check of the built wheel, as a user gets it: a new virtual environment in a temporary
# directory, `pip install WHEEL[study]` (the runtime dependencies and the extra the examples and
# `flexclear montecarlo` need), then, from a directory outside the repository, every ```python
# block of README.md (scripts/readme_examples.py; `<!-- skip-example -->` before a block skips it)
# and the command line's quick paths, each with a small --out in the temporary directory.
#   bash scripts/fresh_venv_check.sh [WHEEL]    (default: the one wheel in target/dist)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
wheel=${1:-}
if [ -z "$wheel" ]; then
  shopt -s nullglob
  wheels=("$root"/target/dist/flexclear-*.whl)
  shopt -u nullglob
  [ ${#wheels[@]} -eq 1 ] || { echo "expected one wheel in target/dist, found ${#wheels[@]} (run scripts/setup.sh)" >&2; exit 1; }
  wheel=${wheels[0]}
fi
wheel=$(cd "$(dirname "$wheel")" && pwd)/$(basename "$wheel")
tmp=$(mktemp -d "${TMPDIR:-/tmp}/flexclear-fresh.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
python3 -m venv "$tmp/venv"
py=$tmp/venv/bin/python
echo "-- pip install $(basename "$wheel")[study] into $tmp/venv"
"$py" -m pip install -q --disable-pip-version-check "$wheel[study]"
"$py" -m pip check --disable-pip-version-check
mkdir "$tmp/work"
cd "$tmp/work"
export MPLBACKEND=Agg
where=$("$py" -I -c "import flexclear._core as c; print(c.__file__)")
case $where in
  "$tmp/venv/"*) echo "-- flexclear imported from $where" ;;
  *) echo "flexclear is imported from $where, not from the fresh venv" >&2; exit 1 ;;
esac

echo "-- README.md examples"
"$py" -I "$root/scripts/readme_examples.py" "$root/README.md"

cli() {
  echo "-- flexclear $*"
  local t0=$SECONDS
  if ! "$tmp/venv/bin/flexclear" "$@" >"$tmp/cli.out" 2>"$tmp/cli.err"; then
    cat "$tmp/cli.out" "$tmp/cli.err"
    echo "flexclear $*: failed" >&2
    exit 1
  fi
  echo "   ok ($((SECONDS - t0)) s)"
}
cli --help
cli frequencies --elements 12 --count 3
grep -q "mode 1: 880\." "$tmp/cli.out" || { cat "$tmp/cli.out"; echo "flexclear frequencies: mode 1 is not 880 Hz" >&2; exit 1; }
cli accuracy --quick --out "$tmp/out/accuracy"
cli paper --out "$tmp/out/paper" --fig6-t-end 0.02
cli spin-up --out "$tmp/out/spin-up" --t-end 2 --speeds 5
cli slider-crank --out "$tmp/out/slider-crank" --t-end 0.01 --clearance-at crank_pin
cli four-bar --out "$tmp/out/four-bar" --t-end 0.02
cat >"$tmp/study.toml" <<'TOML'
scene = "slider_yoke"
samples = 16
design = "lhs"
seed = 1
[run]
t_end = 0.02
dt = 1e-5
[vary.clearance]
distribution = "uniform"
low = 0.0
high = 1e-3
TOML
cli montecarlo "$tmp/study.toml" --out "$tmp/out/study" --threads 2 --no-progress
cli montecarlo "$tmp/study.toml" --out "$tmp/out/study" --threads 2 --no-progress   # resumes: nothing to run
echo "-- fresh venv: ok"
