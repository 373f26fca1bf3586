"""Monte Carlo benchmark: the reference clearance study on 1 and 2 threads, memory, and Exudyn.

The reference study (benches/studies/table1_clearance.toml): the Table 1 slider-yoke with the
radial clearance uniform in [0, 1e-3] m, 0.5 s at dt 1e-5 s, 1000 samples, modified method.

1. Throughput: the same study on 1 and on 2 threads, alternating (``--repeats``), samples/s
   medians and their ratio.
2. Memory: peak RSS of fresh processes running the study with 10x more steps per sample (must not
   grow), and with 10x more samples (bytes per sample).
3. Exudyn: ``exudyn.processing.ParameterVariation`` on the first ``--exudyn-samples`` clearances
   of the same study (2 processes, same scene and outputs; Exudyn may cut its step where its
   Newton fails), samples/s against flexclear's 2-thread samples/s, and the outputs of both side
   by side.

    python benches/montecarlo.py [--samples 1000] [--repeats 3] [--exudyn-samples 8] [--lanes 1,8]
    python benches/montecarlo.py --study slider-crank [--samples 256] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import bench_host  # benches/bench_host.py: which machine a run was on

HERE = os.path.dirname(os.path.abspath(__file__))
#: The reference studies (``--study``): the Table 1 slider-yoke (the default) and Simeon's
#: slider-crank with a crank-pin clearance (issue 14 item 5; its samples run on the Newton
#: stepper, one lane each: there is no lockstep for moving frames yet; its Exudyn counterpart is
#: ``exudyn_crank_scene.parameter_function`` with the same clearance, K_B and crank speed).
STUDIES = {
    "table1": os.path.join(HERE, "studies", "table1_clearance.toml"),
    "slider-crank": os.path.join(HERE, "studies", "slider_crank_clearance.toml"),
}
STUDY_FILE = STUDIES["table1"]


#: The outputs timed against Exudyn: the joint reductions its parameter function computes too
#: (the study files also ask for contact modes, slider deviations and link peaks, which Exudyn's
#: side does not compute).
COMPARED_OUTPUTS = [
    "max_penetration",
    "max_force",
    "contact_episodes",
    "contact_time",
    "max_impact_velocity",
    "rms_force",
]


def reference_study(samples: int, t_end: float = 0.5, dt: float = 1e-5, study_file: str = STUDY_FILE):
    from flexclear.study import Study, load

    base = load(study_file)
    d = base.to_dict()
    d.update(samples=samples, t_end=t_end, dt=dt, outputs=COMPARED_OUTPUTS)
    for key in ("sliders", "links"):
        d.pop(key, None)
    return Study.from_dict(d)


def throughput(samples: int, repeats: int, lanes: list[int], study_file: str = STUDY_FILE) -> dict:
    """Samples/s on 1 and 2 threads for each lockstep lane count (1 = every sample alone), the
    configurations alternating (their order reversed every other repeat) so that load from other
    processes spreads over all of them; medians over the repeats."""
    t_end = 0.1 if study_file == STUDIES["slider-crank"] else 0.5
    study = reference_study(samples, t_end=t_end, study_file=study_file)
    configs = [(th, ln) for ln in lanes for th in (1, 2)]
    times: dict = {c: [] for c in configs}
    frames = {}
    for r in range(repeats):
        order = configs if r % 2 == 0 else configs[::-1]
        for th, ln in order:
            t0 = time.perf_counter()
            result = study.run(threads=th, lanes=ln, progress=False)
            times[(th, ln)].append(time.perf_counter() - t0)
            frames[(th, ln)] = result.frame
            print(f"  threads={th} lanes={ln}: {samples / times[(th, ln)][-1]:.1f} samples/s", flush=True)
    # every configuration computed the same thing, bit for bit
    first = frames[configs[0]].drop(columns="wall_time")
    for c in configs[1:]:
        other = frames[c].drop(columns="wall_time")
        assert first.equals(other), f"threads/lanes {c} differ from {configs[0]}"
    med = {c: statistics.median(v) for c, v in times.items()}
    rate = {c: samples / t for c, t in med.items()}
    best = max(lanes)
    return {
        "samples": samples,
        "lanes": lanes,
        "rate": rate,
        "rate_1": rate[(1, best)],
        "rate_2": rate[(2, best)],
        "scaling": {ln: med[(1, ln)] / med[(2, ln)] for ln in lanes},
        "lockstep_gain": {th: med[(th, min(lanes))] / med[(th, best)] for th in (1, 2)},
        "cpu_per_sample_ms": {c: 1e3 * float(f["wall_time"].mean()) for c, f in frames.items()},
        "frame": frames[(2, best)],
    }


MEMORY_CHILD = """
import json, resource, sys
sys.path.insert(0, {here!r})
from montecarlo import reference_study
s = reference_study({samples}, t_end={t_end})
r = s.run(threads=2, progress=False)
assert (r.frame["status"] == "ok").all()
print(json.dumps({{"maxrss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}}))
"""


def peak_rss(samples: int, t_end: float) -> float:
    code = MEMORY_CHILD.format(here=HERE, samples=samples, t_end=t_end)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])["maxrss_kib"] * 1024.0


def memory() -> dict:
    short = peak_rss(200, 0.05)
    long = peak_rss(200, 0.5)
    few = peak_rss(1000, 0.002)
    many = peak_rss(10000, 0.002)
    return {
        "rss_200_samples_5e3_steps": short,
        "rss_200_samples_5e4_steps": long,
        "rss_1000_samples": few,
        "rss_10000_samples": many,
        "bytes_per_sample": (many - few) / 9000,
    }


def exudyn_subset(frame, count: int) -> dict:
    sys.path.insert(0, HERE)
    import exudyn_scene  # noqa: F401  (selects Exudyn's fast build first)
    from exudyn.processing import ParameterVariation
    from exudyn_scene import parameter_function

    clearances = [float(c) for c in frame["clearance"].iloc[:count]]
    t0 = time.perf_counter()
    _params, values = ParameterVariation(
        parameter_function,
        {"clearance": clearances},
        useMultiProcessing=True,
        numberOfThreads=2,
        showProgress=False,
        parameterFunctionData={"dt": 1e-5, "t_end": 0.5, "elements": 12},
    )
    seconds = time.perf_counter() - t0
    return {"clearances": clearances, "values": values, "seconds": seconds, "rate": count / seconds}


def exudyn_crank_subset(frame, count: int) -> dict:
    """The first ``count`` samples of the slider-crank reference study in Exudyn's
    ``ParameterVariation`` (benches/exudyn_crank_scene.py: ANCF rod, the same law, Newmark at the
    study's step, its step halving on), 2 processes."""
    sys.path.insert(0, HERE)
    import exudyn_crank_scene  # noqa: F401  (selects Exudyn's fast build first)
    from exudyn.processing import ParameterVariation

    rows = frame.iloc[:count]
    # ParameterVariation varies each parameter over a list; with useLoop=False (the default) it
    # would take the product: give one list of sample indices and look the inputs up instead
    samples = [
        {k: float(rows[k].iloc[i]) for k in ("clearance", "bearing_stiffness", "crank_speed")}
        for i in range(count)
    ]
    t0 = time.perf_counter()
    _params, values = ParameterVariation(
        _crank_sample,
        {"sample": list(range(count))},
        useMultiProcessing=True,
        numberOfThreads=2,
        showProgress=False,
        parameterFunctionData={"samples": samples, "dt": 1e-5, "t_end": 0.1, "elements": 8},
    )
    seconds = time.perf_counter() - t0
    return {"samples": samples, "values": values, "seconds": seconds, "rate": count / seconds}


def _crank_sample(parameters: dict) -> list:
    """ParameterVariation's function for one slider-crank sample (by index)."""
    sys.path.insert(0, HERE)
    from exudyn_crank_scene import parameter_function

    data = parameters["functionData"]
    inputs = data["samples"][int(parameters["sample"])]
    return parameter_function({**inputs, "functionData": data})


def print_rates(ex: dict, tp: dict, lanes: list[int]) -> None:
    """Exudyn's samples/s on its subset beside flexclear's on the whole study, and their ratio."""
    n = len(ex["values"])
    print(f"Exudyn: {ex['rate']:.3f} samples/s ({ex['seconds']:.1f} s for {n})")
    print(f"flexclear (2 threads, lanes={max(lanes)}, whole study): {tp['rate_2']:.1f} samples/s")
    print(f"ratio flexclear / Exudyn: {tp['rate_2'] / ex['rate']:.1f}x")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument(
        "--study",
        choices=sorted(STUDIES),
        default="table1",
        help="the reference study: the Table 1 slider-yoke (default) or the crank-pin slider-crank "
        "(throughput only: no memory or Exudyn part)",
    )
    ap.add_argument("--repeats", type=int, default=3, help="alternating 1- and 2-thread runs")
    ap.add_argument("--exudyn-samples", type=int, default=8, help="0 skips Exudyn")
    ap.add_argument("--skip-memory", action="store_true")
    ap.add_argument(
        "--lanes",
        default="1,8",
        help="comma-separated lockstep lane counts to compare (1 = no lockstep; the largest is the "
        "configuration compared with Exudyn)",
    )
    args = ap.parse_args(argv)
    import flexclear

    study_file = STUDIES[args.study]
    crank = args.study == "slider-crank"
    print(f"flexclear {flexclear.__version__}; reference study {study_file}")
    print(bench_host.describe())
    steps = "T = 0.1 s, dt = 1e-5 s (1e4 steps each)" if crank else "T = 0.5 s, dt = 1e-5 s (5e4 steps each)"
    print(f"== throughput: {args.samples} samples, {steps}")
    print(f"load average before: {os.getloadavg()}")
    lanes = sorted({int(x) for x in args.lanes.split(",")})
    tp = throughput(args.samples, args.repeats, lanes, study_file)
    for ln in lanes:
        r1, r2 = tp["rate"][(1, ln)], tp["rate"][(2, ln)]
        print(
            f"median, lanes={ln}: 1 thread {r1:.1f} samples/s, 2 threads {r2:.1f} samples/s; "
            f"scaling 2/1 = {tp['scaling'][ln]:.2f}x; CPU per sample "
            f"{tp['cpu_per_sample_ms'][(1, ln)]:.1f} ms"
        )
    if len(lanes) > 1:
        g = tp["lockstep_gain"]
        print(
            f"lockstep gain (lanes={max(lanes)} vs {min(lanes)}): 1 thread {g[1]:.2f}x, 2 threads {g[2]:.2f}x"
        )
    print(f"load average after: {os.getloadavg()}")
    if crank:
        if args.exudyn_samples > 0:
            n = args.exudyn_samples
            print(f"== Exudyn ParameterVariation, first {n} samples of the slider-crank study, 2 processes")
            ex = exudyn_crank_subset(tp["frame"], n)
            print_rates(ex, tp, lanes)
            print("clearance [m] | K_B [N/m] | w [rad/s] | max force [N] flexclear / Exudyn | closings")
            for i, (inp, v) in enumerate(zip(ex["samples"], ex["values"])):
                row = tp["frame"].iloc[i]
                print(
                    f"{inp['clearance']:.3e} | {inp['bearing_stiffness']:.3e} | {inp['crank_speed']:.1f} | "
                    f"{row['crank_pin.max_force']:.1f} / {v[1]:.1f} | "
                    f"{int(row['crank_pin.contact_episodes'])} / {v[2]}  (Exudyn steps {v[3]})"
                )
        return 0
    if not args.skip_memory:
        print("== memory (peak RSS of fresh processes, 2 threads)")
        m = memory()
        print(
            f"200 samples x 5e3 steps: {m['rss_200_samples_5e3_steps'] / 2**20:.1f} MiB; "
            f"200 samples x 5e4 steps: {m['rss_200_samples_5e4_steps'] / 2**20:.1f} MiB"
        )
        print(
            f"1000 samples: {m['rss_1000_samples'] / 2**20:.1f} MiB; 10000 samples: "
            f"{m['rss_10000_samples'] / 2**20:.1f} MiB; {m['bytes_per_sample']:.0f} bytes per sample"
        )
    if args.exudyn_samples > 0:
        n = args.exudyn_samples
        print(f"== Exudyn ParameterVariation, first {n} clearances, 2 processes")
        ex = exudyn_subset(tp["frame"], n)
        print_rates(ex, tp, lanes)
        print(
            "clearance [m] | max penetration [m] flexclear / Exudyn | "
            "max force [N] flexclear / Exudyn | closings"
        )
        for i, (c, v) in enumerate(zip(ex["clearances"], ex["values"])):
            row = tp["frame"].iloc[i]
            print(
                f"{c:.4e} | {row['bearing.max_penetration']:.4e} / {v[0]:.4e} | "
                f"{row['bearing.max_force']:.3f} / {v[1]:.3f} | "
                f"{int(row['contact_episodes'])} / {int(v[2])}  (Exudyn steps {int(v[3])})"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
