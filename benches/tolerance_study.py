"""A study driven by a tolerance against the same study at fixed steps (issue 17's study target).

The slider-crank reference study (benches/studies/slider_crank_clearance.toml: crank-pin
clearance, bearing stiffness and crank speed varied, 0.1 s per sample) on its first
``--samples`` samples, one thread:

1. ``Study(tol=TOL)`` (adaptive steps; its pilot runs the first samples at ``tol`` and
   ``tol / 10`` and says whether the key outputs, largest force and penetration, met ``tol``),
   on the default output grid of a tolerance run (``t_end / 1000``; ``--grid``: the study
   file's 1e-5 s costs about 6 % more, the interpolated output instants);
2. the same study at fixed steps ``--dts`` (implicit contact, the scene's default run);
3. a reference: the same study at ``tol = TOL / 100``.

Per configuration: samples/s (CPU of the study's run, medians of ``--repeats`` alternating
runs; the pilot is timed apart and not counted) and the accuracy of the key outputs against the
reference (the largest relative difference over the samples). The fixed step that reaches the
tolerance study's accuracy is the longest whose accuracy is as good; the ratio of samples/s is
the target's measure (3x or more).

    python benches/tolerance_study.py [--samples 16] [--tol 0.01] [--dts 1e-5,3e-6,1e-6] [--repeats 3]

Measured (16 samples, 3 repeats, one thread, at ec86e8f): tol 0.01 69.5 samples/s, key outputs
within 6.4e-3 of the reference (pilot: met, 4.5e-3); dt 1e-5 29.6 (3.1e-2), 3e-6 13.4 (1.8e-2),
1e-6 4.6 (4.7e-3): the longest fixed step within the tolerance is 1e-6 s, 15.0 x slower (7.5 x
before the rotations entered the error norm by the displacement they make, 27.5 against 3.7
samples/s on a slower host).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
STUDY_FILE = os.path.join(HERE, "studies", "slider_crank_clearance.toml")
KEYS = ("max_force", "max_penetration")


def study(samples: int, **run):
    from flexclear.study import Study, load

    d = load(STUDY_FILE).to_dict()
    d.update(samples=samples, t_end=0.1, **run)
    return Study.from_dict(d)


def key_columns(frame) -> list[str]:
    return [c for c in frame.columns if c.endswith(KEYS)]


def accuracy(frame, ref) -> float:
    """Largest relative difference of the key outputs over the samples (NaN if any failed)."""
    if not ((frame["status"] == "ok").all() and (ref["status"] == "ok").all()):
        return float("nan")
    errs = []
    for c in key_columns(ref):
        x, y = frame[c].to_numpy(float), ref[c].to_numpy(float)
        errs.append(np.max(np.abs(x - y) / np.abs(y)))
    return float(max(errs))


def timed(s) -> tuple[float, object]:
    t0 = time.process_time()
    r = s.run(threads=1, progress=False, lanes=1)
    return time.process_time() - t0, r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--tol", type=float, default=0.01)
    ap.add_argument("--dts", default="1e-5,3e-6,1e-6", help="fixed steps, s")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--grid", type=float, default=None, help="tolerance study output grid, s")
    a = ap.parse_args()
    n, tol = a.samples, a.tol
    dts = [float(x) for x in a.dts.split(",")]

    ref = study(n, tol=tol / 100, dt=None)
    t_ref, r_ref = timed(ref)
    print(f"reference: tol = {tol / 100:g}, {n} samples in {t_ref:.1f} s CPU (its own pilot included)")
    tol_study = study(n, tol=tol, dt=a.grid)
    t0 = time.process_time()
    pilot = tol_study.pilot(tol_study.inputs(), threads=1)
    t_pilot = time.process_time() - t0
    keys = {c: v for c, v in pilot["accuracy"].items() if c.endswith(KEYS)}
    print(
        f"pilot of tol = {tol:g} ({pilot['samples']} samples, {t_pilot:.1f} s CPU): met = {pilot['met']}, "
        + ", ".join(f"{c} {v:.2e}" for c, v in keys.items())
    )
    configs = [("tol", tol)] + [("dt", dt) for dt in dts]
    times: dict = {c: [] for c in configs}
    frames = {}
    for r in range(a.repeats):
        for c in configs if r % 2 == 0 else configs[::-1]:
            s = study(n, tol=c[1], dt=a.grid) if c[0] == "tol" else study(n, dt=c[1])
            if c[0] == "tol":
                # the pilot once, above: the timed run reads the samples only
                s.pilot = lambda *args, _p=pilot, **kw: _p
            t, res = timed(s)
            times[c].append(t)
            frames[c] = res.frame
    rate = {c: n / statistics.median(times[c]) for c in configs}
    acc = {c: accuracy(frames[c], r_ref.frame) for c in configs}
    for c in configs:
        label = f"tol = {c[1]:g}" if c[0] == "tol" else f"dt = {c[1]:g} s"
        print(f"{label:14s} {rate[c]:8.2f} samples/s   key outputs within {acc[c]:.2e} of the reference")
    t_acc = acc[("tol", tol)]
    for what, bound in (("the tolerance", tol), ("the tolerance study's accuracy", t_acc)):
        reached = [c for c in configs[1:] if acc[c] <= bound]
        if reached:
            best = max(reached, key=lambda c: c[1])
            print(
                f"longest fixed step within {what} ({bound:.2e}): dt = {best[1]:g} s; the tolerance "
                f"study runs {rate[('tol', tol)] / rate[best]:.2f} x its samples/s"
            )
        else:
            print(f"no fixed step of --dts within {what} ({bound:.2e}): add shorter ones")


if __name__ == "__main__":
    main()
