"""Fixed steps against event-aware stepping on the Table 1 scene (slider-yoke, clearance 1e-4 m,
30 ms): trajectory error (the paper's Fig. 6 density, std), peak contact force, mean peak force
per impact (impact logs) and CPU time, for kappa iterated and kappa lagged, against kappa iterated
with events at --dt-ref. Prints the markdown table of docs/stability.md section 6. With --ked:
the KED table of section 6.1 instead (Simeon's slider-crank, 0.5 mm crank-pin clearance, 50 ms,
largest pin force against events at 1e-7 s).

    python benches/events_table.py [--dt-ref 1e-8] [--repeats 3]
    python benches/events_table.py --ked
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from flexclear import Record, scenes
from flexclear.analysis.accuracy import errors_against

DTS = (1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dt-ref", type=float, default=1e-8)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--ked", action="store_true", help="the KED slider-crank table (section 6.1)")
    a = ap.parse_args()
    if a.ked:
        return ked_table()
    model = scenes.slider_yoke(clearance=1e-4)

    def hist(dt, **kw):
        r = model.simulate(0.03, dt, record=Record(impact_log=True), divergence_limit=1.0, **kw)
        j = r.joint("bearing")
        return (r.time, j.penetration, j.force, j.max_force), j.impact_log

    def cpu(dt, **kw):
        ts = []
        for _ in range(a.repeats):
            t0 = time.process_time()
            model.simulate(0.03, dt, record=Record(histories=False), divergence_limit=1.0, **kw)
            ts.append(time.process_time() - t0)
        return float(np.median(ts))

    ref, ref_log = hist(a.dt_ref, iterate=True, events=True)
    fixed_ref, _ = hist(a.dt_ref, iterate=True)
    e = errors_against(ref, fixed_ref)
    print(
        f"reference: iterated kappa with events at {a.dt_ref:g} s; the fixed-step run at that dt differs by "
        f"{e['fig6_std']:.2g} (fig6_std) and {e['peak_force']:.2g} (peak force)\n"
    )
    cols = ("fig6_std", "peak_force", "impact")
    print(
        "| dt (s) | "
        + " | ".join(f"{c} {lab} fixed / events" for lab in ("iterated", "lagged") for c in cols)
        + " | CPU iterated fixed / events | CPU lagged fixed / events |"
    )
    print("|---" * 9 + "|")
    for dt in DTS:
        cells, cpus = [], []
        for kw in ({"iterate": True}, {}):
            pair = {c: [] for c in cols}
            times = []
            for ev in (False, True):
                h, log = hist(dt, events=ev, **kw)
                err = errors_against(ref, h)
                pair["fig6_std"].append(err["fig6_std"])
                pair["peak_force"].append(err["peak_force"])
                rel = abs(log.peak_force.mean() / ref_log.peak_force.mean() - 1)
                pair["impact"].append(rel if len(log) == len(ref_log) else np.nan)
                times.append(cpu(dt, events=ev, **kw) * 1e3)
            cells += [" / ".join("-" if np.isnan(x) else f"{x:.2g}" for x in pair[c]) for c in cols]
            cpus.append(" / ".join(f"{x:.2g}" for x in times) + " ms")
        print(f"| {dt:.0e} | " + " | ".join(cells + cpus) + " |", flush=True)
    print("\n'-': the run had a different number of impacts than the reference (no per-impact comparison).")


def ked_table() -> None:
    from flexclear import FlexclearError

    m = scenes.slider_crank(clearance_at="crank_pin")

    def run(dt, events):
        t0 = time.process_time()
        r = m.simulate(0.05, dt, record=Record(displacements=False), events=events)
        return r.joint("crank_pin"), time.process_time() - t0

    ref, _ = run(1e-7, True)
    fixed, _ = run(1e-7, False)
    print(
        f"reference: events at 1e-7 s, {ref.max_force:.5g} N ({ref.impacts} impacts); fixed at 1e-7 s: "
        f"{fixed.max_force:.5g} N ({fixed.impacts} impacts)\n"
    )
    print("| dt (s) | fixed: error / impacts / CPU | events: error / impacts / CPU |\n|---|---|---|")
    for dt in (1e-4, 5e-5, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7):
        cells = []
        for ev in (False, True):
            try:
                j, cpu = run(dt, ev)
                cells.append(f"{j.max_force / ref.max_force - 1:+.2g} / {j.impacts} / {cpu:.2g} s")
            except FlexclearError as e:
                cells.append(type(e).__name__)
        print(f"| {dt:.0e} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
