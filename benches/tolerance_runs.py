"""Tolerance-driven runs against fixed steps, side by side (issue 17's single-run targets).

Runs ``Model.simulate`` on one scene with each configuration in turn, the configurations
alternating (their order reversed every other repeat) so that load from other processes spreads
over all of them; prints per configuration the median CPU time (``time.process_time()``), the
steps taken and the error of the largest contact force against the scene's converged reference
(docs/accuracy: slider-yoke 9.2020343 N, extrapolated from fixed event-aware steps; stiff
variant 191.4 N; slider-crank 7975 N; Flores 45870 N). Histories are off (``Record(histories=
False)``): the extremes only, as the accuracy report times its runs.

    python benches/tolerance_runs.py yoke "dt=1e-4,iterate=True,events=True" "tol=0.3" "tol=0.1"
    python benches/tolerance_runs.py crank "dt=1e-6" "tol=3e-2" --repeats 7

Short runs are timed in batches (``--inner``; by default enough runs for 20 ms of the first
configuration), and numpy's BLAS runs on one thread (its idle threads spin after a call, and
``process_time`` charges that spin to the next run timed).

Each configuration is ``key=value`` pairs for ``Model.simulate`` separated by commas (``dt`` is
the step or, with ``tol``, the output grid).
"""

from __future__ import annotations

import os

# numpy's OpenBLAS threads spin for a while after a BLAS call, and process_time() counts them:
# whichever configuration runs next was charged for it (a slider-yoke tol run measured 0.73 ms
# of CPU for 0.50 ms of wall time). One thread each, set before numpy loads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    if not os.environ.get(_var):
        os.environ[_var] = "1"

import argparse  # noqa: E402
import ast  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

#: scene: (builder, window s, reference peak force N, joint or None for the first, divergence limit)
SCENES = {
    "yoke": (lambda fc: fc.scenes.slider_yoke(clearance=1e-4), 0.03, 9.2020343, None, 1.0),
    "stiff": (lambda fc: fc.scenes.slider_yoke_stiff(), 0.03, 191.4, None, 1.0),
    "crank": (
        lambda fc: fc.scenes.slider_crank(clearance_at="crank_pin"),
        2 * np.pi / 150,
        7975.0,
        "crank_pin",
        0.5,
    ),
    "flores": (lambda fc: fc.scenes.flores_slider_crank(), 0.012, 4.587e4, "piston_pin", 1.0),
}


def parse(config: str) -> dict:
    out = {}
    for item in filter(None, (p.strip() for p in config.split(","))):
        key, value = item.split("=", 1)
        try:
            out[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            out[key] = value  # e.g. integrator=generalized-alpha
    return out


def main() -> None:
    import flexclear as fc

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", choices=sorted(SCENES))
    ap.add_argument("configs", nargs="+", help='e.g. "tol=0.3" "dt=1e-4,iterate=True,events=True"')
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument(
        "--inner",
        type=int,
        default=0,
        help="runs per timed sample (default: enough for 20 ms of the first configuration)",
    )
    a = ap.parse_args()
    build, t_end, ref, joint, limit = SCENES[a.scene]
    model = build(fc)
    joint = joint or model.joint_names[0]
    configs = [parse(c) for c in a.configs]
    times: list[list[float]] = [[] for _ in configs]
    last = [None] * len(configs)

    def run(i: int):
        kw = dict(configs[i])
        dt = kw.pop("dt", None)
        return model.simulate(t_end, dt, record=fc.Record(histories=False), divergence_limit=limit, **kw)

    inner = a.inner
    if inner <= 0:
        # short runs are timed in batches, so that the clock's resolution and one-off stalls
        # weigh less
        t0 = time.process_time()
        run(0)
        inner = max(1, min(100, int(0.02 / max(time.process_time() - t0, 1e-6))))
    for r in range(a.repeats):
        order = range(len(configs)) if r % 2 == 0 else reversed(range(len(configs)))
        for i in order:
            t0 = time.process_time()
            for _ in range(inner):
                res = run(i)
            times[i].append((time.process_time() - t0) / inner)
            last[i] = res
    base = statistics.median(times[0])
    print(
        f"{a.scene}: {t_end:g} s, {a.repeats} alternating repeats of {inner} run(s), CPU medians; "
        "ratio against the first"
    )
    for cfg, ts, res in zip(a.configs, times, last):
        med = statistics.median(ts)
        steps = res.stats.get("adaptive_steps") or res.stats["steps"]
        err = abs(res.joint(joint).max_force / ref - 1)
        print(f"  {cfg:45s} {med * 1e3:9.3f} ms  x{med / base:6.3f}  steps {steps:6d}  force error {err:.2e}")


if __name__ == "__main__":
    main()
