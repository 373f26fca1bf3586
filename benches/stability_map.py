"""Measured largest stable and largest accurate step per coupling vs bearing stiffness and damping,
beside the theory: the slider-yoke (clearance 1e-5 m, 20 ms runs) and, with --ked, the KED
slider-crank with a crank-pin clearance (5 ms from rest). Writes stability_map.json/.png (and
ked_stability_map.json/.png) to --out. See docs/stability.md for the theory and the criterion and
flexclear.analysis.stability for the search."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from pathlib import Path

from flexclear.analysis.stability import ked_stability_map, markdown_table, plot_map, stability_map


def _round(x, digits: int = 4):
    """``x`` with every float rounded to ``digits`` significant digits (the JSON stays readable)."""
    if isinstance(x, float) and math.isfinite(x) and x != 0:
        return float(f"{x:.{digits - 1}e}")
    if isinstance(x, dict):
        return {k: _round(v, digits) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_round(v, digits) for v in x]
    return x


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default="stability-report")
    ap.add_argument("--stiffness", type=float, nargs="*", default=[1e3, 1e5, 1e7, 1e9, 1e11, 1e13])
    ap.add_argument("--damping-ratio", type=float, nargs="*", default=[0.0, 0.05, 0.5, 5.0])
    ap.add_argument("--t-end", type=float, default=0.02)
    ap.add_argument("--ked", action="store_true", help="also the KED slider-crank map")
    ap.add_argument("--ked-only", action="store_true", help="only the KED slider-crank map")
    ap.add_argument("--ked-stiffness", type=float, nargs="*", default=[1e7, 1e9, 1e11])
    ap.add_argument("--ked-damping-ratio", type=float, nargs="*", default=[0.0, 0.2])
    ap.add_argument("--ked-t-end", type=float, default=0.0013)
    ap.add_argument("--table", metavar="JSON", help="only print the markdown table of a written map")
    a = ap.parse_args()
    if a.table:
        print(markdown_table(json.loads(Path(a.table).read_text())))
        return
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)

    def log(s: str) -> None:
        print(s, file=sys.stderr, flush=True)

    def write(pts, name: str, scene: str) -> None:
        rows = [json.dumps(_round(dataclasses.asdict(p))) for p in pts]  # one point (with its runs) per line
        (out / f"{name}.json").write_text("[\n" + ",\n".join(rows) + "\n]\n")
        plot_map(pts, out / f"{name}.png", scene)
        (out / f"{name}.md").write_text(markdown_table(pts) + "\n")

    t0 = time.process_time()
    if not a.ked_only:
        pts = stability_map(a.stiffness, a.damping_ratio, t_end=a.t_end, log=log)
        write(pts, "stability_map", f"slider-yoke, clearance 1e-5 m, {a.t_end * 1e3:g} ms")
    if a.ked or a.ked_only:
        pts = ked_stability_map(a.ked_stiffness, a.ked_damping_ratio, t_end=a.ked_t_end, log=log)
        write(pts, "ked_stability_map", f"slider-crank, crank-pin clearance 0.5 mm, {a.ked_t_end * 1e3:g} ms")
    print(f"CPU {time.process_time() - t0:.1f} s; written to {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
