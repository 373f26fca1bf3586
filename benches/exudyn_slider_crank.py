"""Slider-crank benchmark: flexclear vs Exudyn, side by side.

Both tools simulate Simeon's flexible slider-crank (``flexclear.scenes.slider_crank``: crank
0.15 m at 150 rad/s, rigid and driven; rod 0.30 m of 8 x 8 mm steel in 8 elements; slider
0.075552 kg) with a clearance joint at the crank pin (0.5 mm, K_B and C_B as the scene derives
them), or with ideal pins (``--ideal``), from rest in the moving frames (undeformed rod on the rigid
mechanism, journal centred), Newmark beta=1/4 gamma=1/2 at the same step. flexclear runs its
defaults, timed as ``simulate(t_end, dt)`` with the default recording (``Result.wall_time``);
Exudyn (benches/exudyn_crank_scene.py: ``ANCFCable2D``, symbolic user-function contact,
exudynCPPfast, modified Newton, tolerances 1e-5/1e-8, its step halving on: at a fixed step its
Newton fails at the third impact, 2 ms; the steps it takes are counted) is timed over
``SolveSteps`` (the integration) and over ``SolveDynamic``'s whole work (``total``).

Every run is a fresh process (each tool's interpreter may differ: ``--exudyn-python`` for a venv
with Exudyn, ``--python`` for flexclear), the time is measured inside it; repeats alternate the
tools and which one goes first, so that machine-load drift affects both alike. The timed run is the
process's first unless ``--warm``: then each tool first runs the same scene over 1 ms, untimed, in
the same process (a study's steady state: flexclear's first ``simulate`` in a process also pays
one-time initializations, about 0.4 ms, and the first touch of its allocator's memory). Prints
per-tool median us/step (per nominal step t_end/dt), the ratios, and, to show that both computed
the same thing, over the first ``--window`` s: the peak crank-pin contact force, the peak
penetration, the first impact onsets, and the peak midspan deflection of the rod (from the chord),
and the largest differences of the penetration and deflection histories on the grid k dt. The
impact counts need not agree: where the journal grazes the bearing (penetration dipping through
zero by a fraction of a um) every dip counts, and Exudyn's halved steps see more of them; the
episodes reaching ``--significant`` (1 um) are counted apart.

    python benches/exudyn_slider_crank.py [--ideal] [--no-geometric] [--clearance 5e-4] [--elements 8]
        [--dt 1e-5] [--t-end 0.1] [--window 0.02] [--repeats 5] [--warm] [--exudyn-python PYTHON]
        [--python PYTHON] [--baseline-python PYTHON [--baseline-path DIR]]

``--baseline-python`` (and ``--baseline-path``, prepended to its PYTHONPATH) adds a third tool:
another build of flexclear, run and timed the same way, alternating with the other two.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

import bench_host  # benches/bench_host.py: which machine a run was on

HERE = os.path.dirname(os.path.abspath(__file__))


def midspan_deflection(x, y, mid: int):
    """Signed distance of node ``mid`` from the chord of the first and last nodes, per row of the
    node coordinates ``x``, ``y`` (shape (n, nodes)), m (the same formula as in
    exudyn_crank_scene)."""
    import numpy as np

    cx, cy = x[:, -1] - x[:, 0], y[:, -1] - y[:, 0]
    return (-(x[:, mid] - x[:, 0]) * cy + (y[:, mid] - y[:, 0]) * cx) / np.hypot(cx, cy)


def worker_flexclear(case: dict) -> dict:
    """One flexclear run: the scene's defaults, ``simulate(t_end, dt)`` with the default recording;
    time = ``Result.wall_time``. The histories over [0, window] as run_exudyn returns them."""
    import flexclear
    import numpy as np

    at = None if case["clearance"] is None else "crank_pin"
    kw = {} if at is None else {"clearance": case["clearance"]}
    if case.get("geometric") is not None:
        kw["geometric"] = case["geometric"]
    if case.get("warm"):
        warm = flexclear.scenes.slider_crank(clearance_at=at, elements=case["elements"], **kw)
        warm.simulate(1e-3, case["dt"])
    model = flexclear.scenes.slider_crank(clearance_at=at, elements=case["elements"], **kw)
    res = model.simulate(case["t_end"], case["dt"])
    t = np.asarray(res.time)
    win = t <= case["window"] * (1 + 1e-9)
    keys = ("steps", "iterations", "factorizations", "halved_substeps", "unconverged_steps", "stepper")
    x, y = (np.asarray(a) for a in res.link("rod").global_positions())
    out = {
        "tool": f"flexclear {getattr(flexclear, '__version__', '?')} ({flexclear._core.SIMD_PATHS} paths)",
        "seconds": res.wall_time,
        "stats": {k: res.stats.get(k) for k in keys},
        "steps": res.stats["steps"],
        "parameters": {k: v for k, v in model.parameters.items() if isinstance(v, (float, int))},
        "slider_x_end": float(x[-1, -1]),
        "window": {
            "t": t[win].tolist(),
            "midspan": midspan_deflection(x[win], y[win], case["elements"] // 2).tolist(),
        },
    }
    if at is not None:
        j = res.joint(at)
        out["window"].update(
            penetration=np.asarray(j.penetration)[win].tolist(), force=np.asarray(j.force)[win].tolist()
        )
    return out


def worker_exudyn(case: dict) -> dict:
    sys.path.insert(0, HERE)
    import exudyn_crank_scene  # selects exudynCPPfast before exudyn is imported

    warm = case.get("warm")
    case = {k: v for k, v in case.items() if k not in ("geometric", "warm")}
    if warm:
        exudyn_crank_scene.run_exudyn(**{**case, "t_end": 1e-3, "window": 1e-3})
    out = exudyn_crank_scene.run_exudyn(**case)
    out["parameters"] = {
        k: v
        for k, v in exudyn_crank_scene.scene_parameters(case["clearance"], case["elements"]).items()
        if isinstance(v, (float, int))
    }
    return out


def runner(python: str, tool: str, path=None):
    """A tool: runs this file's worker ``tool`` with interpreter ``python`` in a fresh process
    (``path`` prepended to PYTHONPATH) and returns its JSON result."""
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = path + os.pathsep + env.get("PYTHONPATH", "")

    def run(case: dict) -> dict:
        proc = subprocess.run(
            [python, os.path.abspath(__file__), "--worker", tool, json.dumps(case)],
            env=env,
            capture_output=True,
            text=True,
        )
        if proc.returncode != 0:
            raise RuntimeError(f"{tool} run failed ({python}):\n{proc.stderr[-3000:]}")
        return json.loads(proc.stdout.strip().splitlines()[-1])

    return run


def analyse(window: dict) -> dict:
    """Comparison values from a run's histories over the window: peak contact force (N) and
    when, peak penetration (m), the contact episodes (onset, linearly interpolated, s; peak
    penetration, m), peak |midspan deflection| (m) and when."""
    import numpy as np

    t = np.asarray(window["t"])
    d = np.asarray(window["midspan"])
    k = int(np.argmax(np.abs(d)))
    out = {"max_midspan": float(d[k]), "time_of_max_midspan": float(t[k])}
    if "penetration" in window:
        pen, force = np.asarray(window["penetration"]), np.asarray(window["force"])
        k = int(np.argmax(force))
        closed = pen > 0.0
        starts = list(np.nonzero(closed[1:] & ~closed[:-1])[0] + 1)
        ends = list(np.nonzero(~closed[1:] & closed[:-1])[0] + 1) + [len(t)]
        episodes = []
        for a in starts:
            b = min(e for e in ends if e > a)
            onset = t[a - 1] + (t[a] - t[a - 1]) * -pen[a - 1] / (pen[a] - pen[a - 1])
            episodes.append((float(onset), float(pen[a:b].max())))
        out.update(
            max_force=float(force[k]),
            time_of_max_force=float(t[k]),
            max_penetration=float(pen.max()),
            episodes=episodes,
        )
    return out


def max_difference(a: dict, b: dict, key: str, dt: float):
    """Largest |b - a| of history ``key`` on the nominal grid k dt of the window (linear
    interpolation of both tools' histories), and when."""
    import numpy as np

    t_end = min(a["t"][-1], b["t"][-1])
    grid = np.arange(0.0, t_end + 0.5 * dt, dt)
    diff = np.abs(np.interp(grid, b["t"], b[key]) - np.interp(grid, a["t"], a[key]))
    k = int(np.argmax(diff))
    return float(diff[k]), float(grid[k])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ideal", action="store_true", help="ideal pins (no clearance joint)")
    ap.add_argument(
        "--no-geometric",
        action="store_true",
        help="flexclear without the rod's geometric terms (reported apart: not the scene's default)",
    )
    ap.add_argument("--clearance", type=float, default=5e-4, help="crank-pin clearance [m]")
    ap.add_argument("--elements", type=int, default=8, help="rod elements")
    ap.add_argument("--dt", type=float, default=1e-5, help="time step [s]")
    ap.add_argument("--t-end", type=float, default=0.1, help="end time [s]")
    ap.add_argument("--window", type=float, default=0.02, help="comparison window [0, window] [s]")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per tool")
    ap.add_argument(
        "--warm", action="store_true", help="time each tool's second run in its process (after 1 ms untimed)"
    )
    ap.add_argument("--impacts", type=int, default=6, help="impact onsets printed")
    ap.add_argument(
        "--significant", type=float, default=1e-6, help="impacts counted apart: episode peak penetration [m]"
    )
    ap.add_argument("--python", default=sys.executable, help="interpreter with flexclear")
    ap.add_argument("--exudyn-python", default=sys.executable, help="interpreter with exudyn")
    ap.add_argument("--baseline-python", default=None, help="interpreter of a baseline flexclear build")
    ap.add_argument("--baseline-path", default=None, help="PYTHONPATH entry for the baseline build")
    ap.add_argument("--worker", nargs=2, metavar=("TOOL", "CASE"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        tool, case = args.worker
        out = {"flexclear": worker_flexclear, "exudyn": worker_exudyn}[tool](json.loads(case))
        print(json.dumps(out))
        return 0
    if args.repeats < 1:
        ap.error("--repeats must be >= 1")

    case = {
        "clearance": None if args.ideal else args.clearance,
        "elements": args.elements,
        "dt": args.dt,
        "t_end": args.t_end,
        "window": min(args.window, args.t_end),
    }
    if args.no_geometric:
        case["geometric"] = False
    if args.warm:
        case["warm"] = True
    joint = "ideal pins" if args.ideal else f"clearance {args.clearance:g} m at the crank pin"
    print(
        f"slider-crank, {joint}: elements={args.elements}, dt={args.dt:g} s, t_end={args.t_end:g} s, "
        f"{args.repeats} repeats, comparison over [0, {case['window']:g}] s"
        + (", each timed run the second in its process (--warm)" if args.warm else "")
    )
    print(bench_host.describe())
    if args.no_geometric:
        print("!!! flexclear with geometric=False (not the scene's default: these times do not count)")
    tools = {
        "flexclear": runner(args.python, "flexclear"),
        "exudyn": runner(args.exudyn_python, "exudyn"),
    }
    if args.baseline_python:
        tools["baseline"] = runner(args.baseline_python, "flexclear", args.baseline_path)

    results = {name: [] for name in tools}
    names = list(tools)
    nominal = round(args.t_end / args.dt)
    for rep in range(args.repeats):
        order = names if rep % 2 == 0 else names[::-1]
        for name in order:
            r = tools[name](case)
            results[name].append(r)
            if name == "exudyn":
                extra = (
                    f"total {r['seconds_total']:.3f} s, steps={r['steps']} (nominal {r['nominal_steps']}), "
                    f"newton it={r['newton_iterations']}, jacobians={r['jacobians']}"
                )
            else:
                st = r["stats"]
                extra = (
                    f"steps={st['steps']}, iterations={st['iterations']}, "
                    f"factorizations={st['factorizations']}, halved={st['halved_substeps']}"
                )
            peak = "" if args.ideal else f"  peak force {max(r['window']['force']):.1f} N"
            print(f"  run {rep + 1}/{args.repeats} {name:9s}: {r['seconds']:7.3f} s  [{extra}]{peak}")

    print("\ntools: " + ", ".join(f"{n}: {results[n][0]['tool']}" for n in names))
    fc, ex = results["flexclear"][0]["parameters"], results["exudyn"][0]["parameters"]
    keys = ["rod_mass", "area", "inertia"] + ([] if args.ideal else ["bearing_stiffness", "bearing_damping"])
    worst = max(abs(ex[k] / fc[k] - 1.0) for k in keys)
    print(
        "parameters (flexclear = Exudyn model): "
        + ", ".join(f"{k}={fc[k]:.6g}" for k in keys)
        + f"; largest relative difference {worst:.1e}"
    )
    if worst > 1e-12:
        print("!!! WARNING: the Exudyn model's parameters differ from flexclear's scene")

    print(f"\nsummary (median over {args.repeats} repeats, us per nominal step: {nominal} steps)")
    med = {}
    for name in names:
        med[name] = statistics.median(r["seconds"] for r in results[name])
        line = f"  {name:9s}: {med[name]:8.4f} s  {1e6 * med[name] / nominal:8.2f} us/step"
        if name == "exudyn":
            tot = statistics.median(r["seconds_total"] for r in results[name])
            steps = sorted({r["steps"] for r in results[name]})
            line += (
                f"  (SolveSteps; SolveDynamic total {tot:.4f} s = {1e6 * tot / nominal:.2f} us/step; "
                f"steps taken {steps}: {1e6 * med[name] / steps[0]:.2f} us per step taken)"
            )
        print(line)
    print(f"  ratio exudyn/flexclear: {med['exudyn'] / med['flexclear']:.2f} (SolveSteps)")
    if "baseline" in med:
        before, after = med["exudyn"] / med["baseline"], med["exudyn"] / med["flexclear"]
        print(f"  ratio exudyn/baseline:  {before:.2f}  (after/before: {after / before:.3f})")

    w = case["window"]
    print(f"\ncomparison over [0, {w:g}] s (first run of each tool)")
    an = {name: analyse(results[name][0]["window"]) for name in names}
    for name in names:
        r, a = results[name][0], an[name]
        print(
            f"  {name:9s}: slider x at t_end {r['slider_x_end']:.6f} m, peak midspan deflection "
            f"{1e6 * a['max_midspan']:+.2f} um at {1e3 * a['time_of_max_midspan']:.2f} ms"
        )
        if not args.ideal:
            ep = a["episodes"]
            big = sum(1 for _, p in ep if p >= args.significant)
            first = ", ".join(f"{1e3 * t:.3f} ({1e6 * p:.1f})" for t, p in ep[: args.impacts])
            more = " ..." if len(ep) > args.impacts else ""
            tf = 1e3 * a["time_of_max_force"]
            print(
                f"  {'':9s}  peak contact force {a['max_force']:.1f} N at {tf:.3f} ms, "
                f"peak penetration {1e6 * a['max_penetration']:.2f} um\n"
                f"  {'':9s}  {len(ep)} impacts ({big} reaching {1e6 * args.significant:g} um), "
                f"first onsets in ms (episode peak penetration in um): {first}{more}"
            )
    a, b = an["flexclear"], an["exudyn"]
    wa, wb = results["flexclear"][0]["window"], results["exudyn"][0]["window"]
    dm, tm = max_difference(wa, wb, "midspan", args.dt)
    print(
        f"  Exudyn vs flexclear: peak midspan deflection {b['max_midspan'] / a['max_midspan'] - 1:+.2%}; "
        f"midspan deflection histories differ by at most {1e6 * dm:.2f} um (at {1e3 * tm:.2f} ms)"
    )
    if not args.ideal:
        dp, tp = max_difference(wa, wb, "penetration", args.dt)
        n = min(len(a["episodes"]), len(b["episodes"]), 3)
        onsets = ", ".join(f"{1e6 * (b['episodes'][i][0] - a['episodes'][i][0]):+.1f}" for i in range(n))
        print(
            f"  {'':20s} peak contact force {b['max_force'] / a['max_force'] - 1:+.2%}, "
            f"peak penetration {b['max_penetration'] / a['max_penetration'] - 1:+.2%}; "
            f"penetration histories differ by at most {1e6 * dp:.2f} um (at {1e3 * tp:.2f} ms)\n"
            f"  {'':20s} first {n} impact onsets, Exudyn - flexclear: {onsets} us"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
