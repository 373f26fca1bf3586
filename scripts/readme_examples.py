"""Runs every ```python block of a README against the installed flexclear.

    python -I scripts/readme_examples.py README.md [--list] [--workdir DIR]

Blocks run in README order. The blocks of one `## ` section share one namespace (a later block
may use what an earlier one of the same section defined); each section starts afresh. A block
right after the comment `<!-- skip-example -->` (a reason may follow: `<!-- skip-example: slow
-->`; only blank lines may stand between the comment and the fence) is not run. Code runs
compiled under the README's own name with its own line numbers, so a traceback points at the
README line; a failing block ends its section (the rest would fail on missing names) and the run
ends with exit 1 and the failing lines listed.

The blocks run in a fresh temporary directory (or --workdir), with matplotlib's Agg backend. The
script refuses to run when `flexclear` is not imported from an installed package (site-packages),
e.g. from a source tree or an editable install: run it with `python -I` (no script directory, no
PYTHON* variables on sys.path) from outside the repository, where the wheel is installed.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

SKIP = re.compile(r"^\s*<!--\s*skip-example\b.*-->\s*$")


@dataclass
class Block:
    line: int  # README line of the first code line (1-based)
    section: str
    code: str
    skip: bool


def blocks(text: str) -> list:
    out, section, lines = [], "(top)", text.splitlines()
    i = 0
    while i < len(lines):
        s = lines[i]
        if s.startswith("## "):
            section = s[3:].strip()
        fence = re.match(r"^(\s*)(`{3,})\s*(\S*)", s)
        if fence:
            indent, ticks, lang = fence.groups()
            j = i + 1
            while j < len(lines) and not lines[j].strip().startswith(ticks):
                j += 1
            if lang == "python":
                k = i - 1
                while k >= 0 and not lines[k].strip():
                    k -= 1
                skip = k >= 0 and bool(SKIP.match(lines[k]))
                body = lines[i + 1 : j]
                code = "\n".join(line[len(indent) :] if line.startswith(indent) else line for line in body)
                out.append(Block(i + 2, section, code, skip))
            i = j + 1
            continue
        i += 1
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("readme", type=Path)
    ap.add_argument("--list", action="store_true", help="list the blocks and exit")
    ap.add_argument("--workdir", type=Path, help="run in this directory (default: a temporary one)")
    a = ap.parse_args()
    readme = a.readme.resolve()
    found = blocks(readme.read_text())
    name = readme.name
    if a.list:
        for b in found:
            state = "skip" if b.skip else "run"
            print(f"{name}:{b.line}  {state:<4}  [{b.section}]  {b.code.splitlines()[0] if b.code else ''}")
        return 0

    os.environ.setdefault("MPLBACKEND", "Agg")
    import flexclear

    where = Path(flexclear.__file__).resolve()
    if not {"site-packages", "dist-packages"} & set(where.parts):
        print(f"{name}: flexclear is imported from {where.parent}, not from an installed wheel")
        return 2
    print(f"{name}: flexclear {flexclear.__version__} from {where.parent}")

    tmp = None
    if a.workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="readme-examples-")
        a.workdir = Path(tmp.name)
    a.workdir.mkdir(parents=True, exist_ok=True)
    os.chdir(a.workdir)

    failed, ran, skipped = [], 0, 0
    namespaces: dict = {}
    dead: set = set()
    for b in found:
        where = f"{name}:{b.line} [{b.section}]"
        if b.skip:
            skipped += 1
            print(f"{where}: skipped (<!-- skip-example -->)")
            continue
        if b.section in dead:
            print(f"{where}: not run (an earlier block of its section failed)")
            continue
        ns = namespaces.setdefault(b.section, {"__name__": "__readme__"})
        # Padding keeps the README's line numbers in tracebacks.
        code = compile("\n" * (b.line - 1) + b.code, str(readme), "exec")
        t0 = time.perf_counter()
        try:
            exec(code, ns)
        except (Exception, SystemExit):
            dead.add(b.section)
            failed.append(b.line)
            print(f"{where}: FAILED after {time.perf_counter() - t0:.1f} s")
            traceback.print_exc(file=sys.stdout)
            continue
        ran += 1
        print(f"{where}: ok ({time.perf_counter() - t0:.1f} s)")
    if tmp is not None:
        os.chdir("/")
        tmp.cleanup()
    print(f"{name}: {ran} blocks ran, {skipped} skipped, {len(failed)} failed")
    if failed:
        print(f"{name}: failing blocks at line(s) {', '.join(map(str, failed))}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
