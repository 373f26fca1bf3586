"""Measured and theoretical largest stable step per coupling vs bearing stiffness and damping
(slider-yoke, clearance 1e-5 m, 20 ms runs). Writes stability_map.json and stability_map.png to
--out. See docs/stability.md for the theory and flexclear.stability for the search."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

from flexclear.stability import plot_map, stability_map


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default="stability-report")
    ap.add_argument("--stiffness", type=float, nargs="*", default=[1e3, 1e5, 1e7, 1e9, 1e11, 1e13])
    ap.add_argument("--damping-ratio", type=float, nargs="*", default=[0.0, 0.05, 0.5, 5.0])
    ap.add_argument("--t-end", type=float, default=0.02)
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.process_time()
    pts = stability_map(
        a.stiffness, a.damping_ratio, t_end=a.t_end, log=lambda s: print(s, file=sys.stderr, flush=True)
    )
    (out / "stability_map.json").write_text(json.dumps([dataclasses.asdict(p) for p in pts], indent=1))
    plot_map(pts, out / "stability_map.png")
    print(f"CPU {time.process_time() - t0:.1f} s; written to {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
