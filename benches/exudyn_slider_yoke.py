"""Slider-yoke benchmark: flexclear vs Exudyn, side by side.

Both tools simulate the same scene (free-free ANCF/flexible steel beam driven by a
yoke through a 2D clearance bearing, Newmark beta=1/4 gamma=1/2, fixed dt).
Repeats alternate between the tools (and alternate which one goes first) so
that machine-load drift affects both alike. Prints per-tool median wall time,
the ratio exudyn/flexclear, and each tool's max bearing penetration.

    python benches/exudyn_slider_yoke.py [--clearance 1e-5] [--elements 12]
        [--dt 1e-6] [--t-end 0.1] [--repeats 5] [--baseline-python PYTHON [--baseline-path DIR]]

``--baseline-python`` (and ``--baseline-path``, prepended to its PYTHONPATH) adds a third tool:
another build of flexclear (e.g. the commit before a refactoring), run in a subprocess with that
interpreter and timed inside it the same way, alternating with the other two, so "the ratio to
Exudyn before and after the change" comes from one run on one machine state.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bench_host  # benches/bench_host.py: which machine a run was on
import exudyn_scene  # selects exudynCPPfast before exudyn is imported
from exudyn_scene import run_exudyn


def run_flexclear(clearance, elements, dt, t_end) -> dict:
    """Simulate the scene with flexclear (modified method, running extremes only); same keys as
    run_exudyn. ``seconds`` is the wall time of ``Model.simulate`` (assembly, factorization and
    the time loop), like Exudyn's ``SolveDynamic``."""
    import flexclear

    model = flexclear.scenes.slider_yoke(clearance=clearance, elements=elements)
    res = model.simulate(t_end, dt, method="modified", record=flexclear.Record(histories=False))
    return {
        "seconds": res.wall_time,
        "max_penetration": float(res.joint("bearing").max_penetration),
        "steps": res.stats["steps"],
    }


_BASELINE_CODE = """
import json, sys
import flexclear
c = json.loads(sys.argv[1])
m = flexclear.scenes.slider_yoke(clearance=c["clearance"], elements=c["elements"])
r = m.simulate(c["t_end"], c["dt"], method="modified", record=flexclear.Record(histories=False))
print(json.dumps({"seconds": r.wall_time, "max_penetration": float(r.joint("bearing").max_penetration),
                  "steps": r.stats["steps"]}))
"""


def baseline_runner(python: str, path):
    """A tool that runs the scene with another flexclear build in a subprocess (its own
    interpreter, ``path`` prepended to PYTHONPATH); the time is measured inside it."""
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = path + os.pathsep + env.get("PYTHONPATH", "")

    def run(**case) -> dict:
        out = subprocess.run(
            [python, "-c", _BASELINE_CODE, json.dumps(case)],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
        return json.loads(out.stdout.strip().splitlines()[-1])

    return run


def flexclear_available() -> bool:
    try:
        import flexclear  # noqa: F401
    except (ImportError, OSError) as err:  # not built/installed, or a broken build
        print(f"NOTE: flexclear is not importable ({err!r}); running Exudyn alone.")
        return False
    return True


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clearance", type=float, default=1e-5, help="bearing clearance [m]")
    ap.add_argument("--elements", type=int, default=12, help="number of beam elements")
    ap.add_argument("--dt", type=float, default=1e-6, help="fixed time step [s]")
    ap.add_argument("--t-end", type=float, default=0.1, help="end time [s]")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per tool")
    ap.add_argument("--baseline-python", default=None, help="interpreter of a baseline flexclear build")
    ap.add_argument("--baseline-path", default=None, help="PYTHONPATH entry for the baseline build")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error("--repeats must be >= 1")

    case = {
        "clearance": args.clearance,
        "elements": args.elements,
        "dt": args.dt,
        "t_end": args.t_end,
    }
    print(
        "slider-yoke: clearance={clearance:g} m, elements={elements}, dt={dt:g} s, t_end={t_end:g} s".format(
            **case
        )
    )
    print(f"Exudyn: {exudyn_scene.exudyn_info()}")
    print(bench_host.describe())

    tools = {"exudyn": run_exudyn}
    if flexclear_available():
        tools = {"flexclear": run_flexclear, "exudyn": run_exudyn}
    if args.baseline_python:
        tools["baseline"] = baseline_runner(args.baseline_python, args.baseline_path)

    results = {name: [] for name in tools}
    names = list(tools)
    for rep in range(args.repeats):
        order = names if rep % 2 == 0 else names[::-1]
        for name in order:
            if name not in tools:
                continue
            try:
                r = tools[name](**case)
            except Exception as err:
                if name != "flexclear":
                    raise
                # the flexclear API is still moving: report and carry on with Exudyn
                print(f"NOTE: flexclear run failed ({err!r}); adapt run_flexclear().")
                print("      Continuing with Exudyn alone.")
                del tools["flexclear"], results["flexclear"]
                continue
            results[name].append(r)
            extra = ""
            if name == "exudyn":
                info = exudyn_scene.LAST_RUN_INFO
                extra = f"  [uf={info.get('user_function')}, newton it={info.get('newton_iterations')}]"
            print(
                f"  run {rep + 1}/{args.repeats} {name:9s}: {r['seconds']:8.3f} s  "
                f"steps={r['steps']}  max_pen={r['max_penetration']:.6e} m{extra}"
            )

    if exudyn_scene.LAST_RUN_INFO.get("user_function") != "symbolic":
        print("!" * 78)
        print("!!! WARNING: Exudyn used a PYTHON user function (symbolic failed): timing unfair")
        print("!" * 78)

    print("\nsummary (median over repeats)")
    med = {}
    for name, runs in results.items():
        med[name] = statistics.median(r["seconds"] for r in runs)
        pens = [r["max_penetration"] for r in runs]
        steps = runs[-1]["steps"]
        print(
            f"  {name:9s}: {med[name]:8.3f} s  ({1e6 * med[name] / steps:7.2f} us/step)  "
            f"max_penetration={pens[-1]:.6e} m"
            + ("" if max(pens) == min(pens) else f" (varies: {min(pens):.6e}..{max(pens):.6e})")
        )
    if "flexclear" in med:
        print(f"  ratio exudyn/flexclear: {med['exudyn'] / med['flexclear']:.2f}")
        if "baseline" in med:
            before, after = med["exudyn"] / med["baseline"], med["exudyn"] / med["flexclear"]
            print(f"  ratio exudyn/baseline:  {before:.2f}  (after/before: {after / before:.3f})")
    else:
        print("  ratio exudyn/flexclear: n/a (flexclear not available)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
