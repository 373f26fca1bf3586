"""The training workload of the profile-guided build (scripts/setup.sh): runs the paths users run
most through the installed (instrumented) flexclear, so that the compiler lays out and inlines
the hot code as these runs take it. About 30 s on one core.

    python scripts/pgo_train.py

What runs (each a few thousand steps or more):

- the slider-crank (moving frames, Newton stepper, geometric terms) with a clearance at the crank
  pin and at the slider pin, and with ideal pins, each with the default recording and with
  extremes only; event-aware and tolerance-driven runs of the crank pin;
- the four-bar with a clearance at the rocker pin (short contacts, many impacts);
- the paper's slider-yoke (translating links, the constant stepper) with each coupling, and the
  spin-up (a rotating beam without clearance);
- studies of the slider-crank and of the slider-yoke (lockstep lanes), histories off.

PGO changes only code layout and inlining, never a result (no floating-point reassociation):
the golden hashes (scripts/golden.py) are the same for either build.
"""

from __future__ import annotations

import time

import flexclear as fc
from flexclear import Record
from flexclear.study import Study, Uniform


def main() -> None:
    t0 = time.perf_counter()
    extremes = Record(histories=False)
    modes = Record(histories=False, contact_modes=True)
    for at in ("crank_pin", "slider_pin", None):
        m = fc.scenes.slider_crank(clearance_at=at)
        m.simulate(0.1, 1e-5)
        m.simulate(0.1, 1e-5, record=extremes)
    crank = fc.scenes.slider_crank(clearance_at="crank_pin")
    crank.simulate(0.05, 1e-5, record=modes)
    crank.simulate(0.05, 1e-5, iterate=True, events=True, record=modes)
    crank.simulate(0.05, tol=1e-3)
    four = fc.scenes.four_bar(clearance_at="rocker_pin")
    four.simulate(0.01, 1.5625e-7, record=modes)
    four.simulate(0.03, tol=1e-3, record=modes)
    for method in ("modified", "force", "gap"):
        fc.scenes.slider_yoke(clearance=1e-4).simulate(0.1, 1e-5, method=method)
    fc.scenes.slider_yoke(clearance=1e-4).simulate(0.1, 1e-6, record=extremes)
    fc.scenes.spin_up().simulate(0.2, 1e-4)
    for build, fixed, vary, dt in (
        ("slider_crank", {"clearance_at": "crank_pin"}, {"clearance": Uniform(1e-4, 5e-4)}, 1e-5),
        ("slider_yoke", {}, {"clearance": Uniform(0.0, 1e-3)}, 1e-5),
    ):
        Study(build, fixed=fixed, vary=vary, samples=16, seed=1, t_end=0.05, dt=dt).run(
            threads=1, progress=False
        )
    print(f"pgo training: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
