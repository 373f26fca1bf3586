"""Tolerance runs on the constant stepper against the Newton stepper and fixed steps (issue 17,
item 2): the slider-yoke Table 1 scene (``slider_yoke(clearance=1e-4)``) and the stiff-bearing
variant (``slider_yoke_stiff()``), 30 ms, only extremes kept. Per run: median CPU
(``time.process_time()``) of ``--repeats`` runs, the peak force and penetration against the
converged references of docs/accuracy (relative error), the stepper, adaptive steps, rejected
steps, located events and factorizations, and the run's achieved-accuracy estimates (``stats``:
``error_estimate`` of the trajectory, ``peak_force_error_estimate``).

    python benches/adaptive_constant.py [--repeats 7]
"""

from __future__ import annotations

import argparse
import statistics
import time

import flexclear as fc

#: Converged references (docs/accuracy/accuracy.md, tests/data/accuracy_references.csv): peak
#: force (N), peak penetration (m).
REFERENCES = {"slider-yoke": (9.202, 3.718e-6), "slider-yoke-stiff": (191.4, 1.086e-9)}
SCENES = {
    "slider-yoke": lambda: fc.scenes.slider_yoke(clearance=1e-4),
    "slider-yoke-stiff": fc.scenes.slider_yoke_stiff,
}
RUNS = (
    dict(tol=0.01),
    # the output grid as the longest step: t_end / 100 instead of the default t_end / 1000
    dict(tol=0.01, dt=3e-4),
    dict(tol=0.01, stepper="newton"),
    dict(tol=1e-3),
    dict(tol=1e-3, stepper="newton"),
    dict(dt=1e-4, iterate=True, events=True),
    dict(dt=3e-5, iterate=True, events=True),
    dict(dt=3e-6, iterate=True, events=True),
    dict(dt=1e-6),
)


def _est(x) -> str:
    """An estimate of ``stats`` as the table shows it (``-`` for a fixed-step run)."""
    return "-" if x is None else f"{x:.1e}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=7)
    a = ap.parse_args()
    print(
        "| scene | run | stepper | CPU (ms) | peak force error | peak penetration error | steps "
        "| rejected | events | factorizations | estimate: trajectory | estimate: peak force |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, build in SCENES.items():
        m = build()
        force, pen = REFERENCES[name]
        for kw in RUNS:
            cpu = []
            for _ in range(a.repeats):
                t0 = time.process_time()
                r = m.simulate(0.03, record=fc.Record(histories=False), **kw)
                cpu.append(time.process_time() - t0)
            j = r.joint(m.joint_names[0])
            s = r.stats
            run = ", ".join(f"{k}={v}" for k, v in kw.items())
            print(
                f"| {name} | {run} | {s['stepper']} | {statistics.median(cpu) * 1e3:.3f} "
                f"| {j.max_force / force - 1:+.1e} | {j.max_penetration / pen - 1:+.1e} "
                f"| {s['adaptive_steps'] or s['steps']} | {s['rejected_steps']} | {s['event_steps']} "
                f"| {s['factorizations']} | {_est(s['error_estimate'])} "
                f"| {_est(s['peak_force_error_estimate'])} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
