"""Golden values of today's results (cases in tests/golden_cases.py).

    python scripts/golden.py --write            # recompute tests/data/golden.json (a change that
                                                # is meant to change results; say so in its commit)
    python scripts/golden.py --check            # recompute and diff against the file (exit 1 on a
                                                # difference): run it before and after a refactoring
    python scripts/golden.py --out A.json       # write elsewhere (e.g. from another build)
    python scripts/golden.py --compare A.json B.json   # bitwise diff of two files

Values are bitwise comparable only between machines of the same CPU level (stored in the file).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import golden_cases as gc  # noqa: E402


def _commit(where: Path) -> str:
    """The commit of the source tree the imported flexclear was built from (if it is one)."""
    try:
        return subprocess.run(
            ["git", "-C", str(where), "rev-parse", "HEAD"], capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _diff(old: dict, new: dict, bitwise: bool) -> int:
    bad = 0
    for name in sorted(set(old["cases"]) | set(new["cases"])):
        if name not in old["cases"] or name not in new["cases"]:
            print(f"{name:34s} present on one side only")
            bad += 1
            continue
        d = gc.compare(
            old["cases"][name],
            new["cases"][name],
            bitwise and name not in gc.NOT_BITWISE,
            rel=gc.RELATIVE.get(name, 1e-12),
        )
        print(f"{name:34s} {'same' if not d else 'DIFFERENT'}")
        for line in d:
            print(f"    {line}")
        bad += bool(d)
    return bad


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", action="store_true")
    g.add_argument("--check", action="store_true")
    g.add_argument("--out")
    g.add_argument("--compare", nargs=2, metavar=("A", "B"))
    args = ap.parse_args(argv)
    if args.compare:
        a, b = (json.loads(Path(p).read_text()) for p in args.compare)
        print(f"A: {a['commit'][:10]} on {a['cpu']}; B: {b['commit'][:10]} on {b['cpu']}")
        return 1 if _diff(a, b, a["cpu"] == b["cpu"]) else 0
    import flexclear

    t0 = time.perf_counter()
    commit = _commit(Path(flexclear.__file__).parent)
    data = {"cpu": gc.cpu_level(), "commit": commit, "cases": gc.compute(flexclear)}
    print(f"{len(data['cases'])} cases in {time.perf_counter() - t0:.1f} s on {data['cpu']}")
    if args.check:
        old = json.loads(gc.GOLDEN_FILE.read_text())
        return 1 if _diff(old, data, old["cpu"] == data["cpu"]) else 0
    path = gc.GOLDEN_FILE if args.write else Path(args.out)
    path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
