"""The ``flexclear`` command line."""

from __future__ import annotations

import argparse
import sys
from typing import Optional


def _default_rotating_table():
    """The Wright et al. (1982) table shipped as package data (``flexclear/data``)."""
    from pathlib import Path

    return Path(__file__).resolve().parent / "data" / "rotating_cantilever_flapwise.csv"


def main(argv: Optional[list] = None) -> int:
    from . import __version__, _core

    parser = argparse.ArgumentParser(prog="flexclear", description=__doc__)
    parser.add_argument(
        "--version",
        action="version",
        version=f"flexclear {__version__} (SIMD paths on this CPU: {_core.SIMD_PATHS})",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("paper", help="reproduce Hong & Kim (1993) Table 1, Fig. 5 and Fig. 6 (slider-yoke)")
    p.add_argument("--out", default="flexclear-report", help="output folder (default: %(default)s)")
    p.add_argument("--fig6-t-end", type=float, default=0.5, help="Fig. 6 window, s (default: %(default)s)")
    f = sub.add_parser("frequencies", help="natural frequencies of the slider-yoke scene (joints open)")
    f.add_argument("--elements", type=int, default=12)
    f.add_argument("--count", type=int, default=5)
    mc = sub.add_parser(
        "montecarlo",
        help="run a Monte Carlo study file (TOML) and write results and a report",
        description="Runs STUDY.toml (see flexclear.study.load for the format). Results go to --out as "
        "Parquet parts beside the study definition, written as samples finish; running the same "
        "command again resumes where it stopped. The report (report.md and PNG plots) is written at the end.",
    )
    mc.add_argument("study", help="the study file (TOML)")
    mc.add_argument("--out", default=None, help="results and report folder (default: the study file's name)")
    mc.add_argument("--threads", type=int, default=0, help="worker threads (default: one per core)")
    mc.add_argument(
        "--lanes",
        type=int,
        default=0,
        help="largest lockstep group of samples sharing a factorization, 1..8 (default: 8; 1 = no lockstep)",
    )
    mc.add_argument("--chunk-size", type=int, default=None, help="samples per Parquet part / Dask task")
    mc.add_argument("--scheduler", default=None, help="address of a Dask scheduler to run on")
    mc.add_argument(
        "--local-cluster", type=int, default=0, metavar="N", help="start a local Dask cluster of N workers"
    )
    mc.add_argument("--no-progress", action="store_true", help="no progress bar")
    mc.add_argument(
        "--orbits",
        type=int,
        default=3,
        metavar="N",
        help="journal orbits of N samples (smallest, median, largest peak force of the first joint), "
        "run again with the journal position recorded (default 3; 0 = none)",
    )
    cp = sub.add_parser(
        "compare",
        help="do two study stores give the same output distributions? (e.g. one study at two steps)",
        description="Compares the outputs of study store A with those of store B, the reference (e.g. "
        "the same study file run at a finer dt or a smaller tol): per output the relative difference of "
        "the median, the 90 % quantile and the mean with bootstrap intervals (over the pairs of samples "
        "when both ran the same inputs) and the Kolmogorov-Smirnov p-value. Prints a Markdown table.",
    )
    cp.add_argument("a", help="study store (the --out folder of flexclear montecarlo)")
    cp.add_argument("b", help="the reference study store")
    cp.add_argument("--outputs", nargs="+", default=None, help="output columns (default: all shared)")
    cp.add_argument("--confidence", type=float, default=0.95, help="interval level (default: %(default)s)")
    cp.add_argument(
        "--rtol",
        type=float,
        default=0.0,
        help="relative difference that matters, e.g. 0.02: each output then differs, is within it or is "
        "undecided (default: %(default)s, any difference shown)",
    )
    cp.add_argument("--out", default=None, help="also write the table to this Markdown file")
    cp.add_argument(
        "--plots",
        default=None,
        metavar="FOLDER",
        help="also save compare.png (the differences with their intervals) and compare_ecdf.png (both "
        "distributions) there",
    )
    cv = sub.add_parser(
        "converge",
        help="which step or tol does a study need? its distributions at each against the finest",
        description="Runs the first --samples of STUDY.toml at each fixed step of --dt and each tolerance "
        "of --tol (the same inputs for all), compares each with the finest (the smallest dt, else the "
        "smallest tol) as flexclear compare does, and prints a Markdown table: CPU time, speedup, the "
        "paired mean difference of each judged output with its interval, a verdict against --rtol and "
        "the cheapest setting within it.",
    )
    cv.add_argument("study", help="the study file (TOML)")
    cv.add_argument("--dt", type=float, nargs="+", default=[], help="fixed steps, s")
    cv.add_argument("--tol", type=float, nargs="+", default=[], help="tolerances")
    cv.add_argument("--samples", type=int, default=32, help="the first N samples (default: %(default)s)")
    cv.add_argument(
        "--outputs", nargs="+", default=None, help="outputs judged (default: peak force and penetration)"
    )
    cv.add_argument(
        "--rtol", type=float, default=0.02, help="relative difference that matters (default: %(default)s)"
    )
    cv.add_argument(
        "--events",
        action="store_true",
        help="also each step but the finest with event-aware steps (contact entries and exits cut)",
    )
    cv.add_argument("--threads", type=int, default=0, help="worker threads (default: one per core)")
    cv.add_argument("--out", default=None, help="also write the report to this Markdown file")
    cv.add_argument(
        "--plots",
        default=None,
        metavar="FOLDER",
        help="also save convergence.png there (each setting's difference against its CPU time)",
    )
    su = sub.add_parser(
        "spin-up",
        help="spin-up of a cantilever with and without geometric stiffening; in-plane frequency vs speed",
        description="Runs flexclear.scenes.spin_up with and without geometric stiffness (the unstiffened "
        "run diverges: what it computed until then is plotted) and the first two in-plane frequencies "
        "at constant hub speeds. Writes PNG plots and summary.md into --out.",
    )
    su.add_argument("--out", default="spin-up", help="output folder (default: %(default)s)")
    su.add_argument("--dt", type=float, default=1e-3, help="time step, s (default: %(default)s)")
    su.add_argument("--t-end", type=float, default=20.0, help="end time, s (default: %(default)s)")
    su.add_argument("--elements", type=int, default=10, help="beam elements (default: %(default)s)")
    su.add_argument(
        "--data", choices=("kane", "simo"), default="kane", help="data set (default: %(default)s)"
    )
    su.add_argument(
        "--speeds", type=int, default=41, help="hub speeds of the frequency plot (default: %(default)s)"
    )
    su.add_argument("--max-speed", type=float, default=None, help="top hub speed, rad/s (default: 2.5 W)")
    su.add_argument(
        "--reference",
        default=_default_rotating_table(),
        metavar="CSV",
        help="table to overlay on the frequency plot: '#' comments, a header, rows 'lambda, w1, w2, ...' "
        "nondimensional by sqrt(EI/(rho A L^4)), flapwise (converted to in-plane by w^2 - Omega^2); "
        "default: the published table shipped with flexclear (Wright et al. 1982)",
    )
    su.add_argument(
        "--reference-inplane", action="store_true", help="the --reference table is in-plane already"
    )
    sc = sub.add_parser(
        "slider-crank",
        help="Simeon's flexible slider-crank: rod deflection and axial force, optional clearance joint",
    )
    sc.add_argument("--out", default="slider-crank", help="output folder (default: %(default)s)")
    sc.add_argument("--dt", type=float, default=1e-5, help="time step, s (default: %(default)s)")
    sc.add_argument("--t-end", type=float, default=0.1, help="end time, s (default: %(default)s)")
    sc.add_argument("--elements", type=int, default=8, help="rod elements (default: %(default)s)")
    sc.add_argument(
        "--clearance-at",
        choices=("crank_pin", "slider_pin"),
        default=None,
        help="also run with a clearance joint here",
    )
    sc.add_argument(
        "--clearance", type=float, default=5e-4, help="radial clearance, m (default: %(default)s)"
    )
    sc.add_argument(
        "--method", choices=("modified", "force"), default="modified", help="clearance joint method"
    )
    fb = sub.add_parser("four-bar", help="four-bar with a flexible coupler: coupler midspan deflection")
    fb.add_argument("--out", default="four-bar", help="output folder (default: %(default)s)")
    fb.add_argument("--dt", type=float, default=1e-4, help="time step, s (default: %(default)s)")
    fb.add_argument("--t-end", type=float, default=None, help="end time, s (default: three crank turns)")
    fb.add_argument("--elements", type=int, default=6, help="coupler elements (default: %(default)s)")
    fb.add_argument(
        "--crank-speed", type=float, default=100.0, help="crank speed, rad/s (default: %(default)s)"
    )
    fb.add_argument("--flexible-rocker", action="store_true", help="model the rocker as a flexible link too")
    fl = sub.add_parser(
        "flores",
        help="the Flores slider-crank: journal orbit, contact force, slider acceleration and crank moment "
        "against the ideal joints for clearances 0.5, 0.25, 0.1 mm",
    )
    fl.add_argument("--out", default="flores", help="output folder (default: %(default)s)")
    fl.add_argument("--dt", type=float, default=2.5e-7, help="time step, s (default: %(default)s)")
    fl.add_argument(
        "--no-kelvin-voigt",
        action="store_true",
        help="leave out the Kelvin-Voigt runs of the cost comparison",
    )
    ac = sub.add_parser(
        "accuracy",
        help="speed/accuracy per method and scene: Pareto fronts and recommendation tables",
        description="Sweeps dt (and element count) of every method against a converged reference for "
        "each scene and writes accuracy.md (a summary and a section per scene), pareto_<scene>.png and "
        "cases_<scene>.json into --out. The full report of every scene takes about 2-3 min CPU in a "
        "release build.",
    )
    ac.add_argument("--out", default="flexclear-accuracy", help="output folder (default: %(default)s)")
    ac.add_argument(
        "--quick", action="store_true", help="CI-sized sweeps (shorter windows, coarser references)"
    )
    ac.add_argument(
        "--scene",
        choices=("slider-yoke", "slider-yoke-stiff", "slider-crank", "flores", "spin-up", "all"),
        default="all",
        help="which scene (default: %(default)s)",
    )
    de = sub.add_parser(
        "design",
        help="contact-loss prediction vs the clearance simulation (slider-yoke); the preload optimization "
        "of a slider-crank",
        description="Writes design.md and PNGs into --out: the zero-clearance bearing force polar with the "
        "predicted contact-loss intervals beside the clearance run's contact timeline, how the "
        "predictions meet the runs' departures from the wall over a sweep of clearance, and the worked "
        "optimization (the slider-crank preload that minimizes the peak crank-pin force). About 30 s; "
        "--quick about 8 s.",
    )
    de.add_argument("--out", default="flexclear-design", help="output folder (default: %(default)s)")
    de.add_argument("--t-end", type=float, default=0.2, help="simulated time, s (default: %(default)s)")
    de.add_argument(
        "--quick", action="store_true", help="a coarse preload sweep and a short optimization (a smoke test)"
    )
    args = parser.parse_args(argv)
    from .errors import FlexclearError

    # A bad value (out of range, a missing file) is a usage error of the subcommand, reported as
    # argparse reports one (its usage, then "prog: error: message"; status 2), without a traceback.
    try:
        return _run(args)
    except KeyboardInterrupt:
        print(f"\nflexclear {args.command}: interrupted", file=sys.stderr)
        return 130
    except (FlexclearError, OSError) as e:
        sp = sub.choices[args.command]
        sp.print_usage(sys.stderr)
        print(f"{sp.prog}: error: {e}", file=sys.stderr)
        return 2


def _run(args) -> int:
    if args.command == "accuracy":
        return _accuracy(args)
    if args.command == "design":
        from .design.report import write_report as design_report

        path = design_report(
            args.out, t_end=args.t_end, quick=args.quick, log=lambda s: print(s, file=sys.stderr)
        )
        print(path.read_text())
        print(f"report written to {path}", file=sys.stderr)
        return 0
    if args.command == "flores":
        from .reports.flores import flores_report

        path = flores_report(
            args.out,
            dt=args.dt,
            kelvin_voigt=not args.no_kelvin_voigt,
            log=lambda s: print(s, file=sys.stderr),
        )
        print(path.read_text())
        print(f"report written to {path}", file=sys.stderr)
        return 0
    if args.command == "paper":
        from .reports.paper import write_report

        path = write_report(args.out, fig6_t_end=args.fig6_t_end, log=lambda s: print(s, file=sys.stderr))
        print(path.read_text())
        print(f"report written to {path}", file=sys.stderr)
    elif args.command == "frequencies":
        from . import scenes

        for i, fr in enumerate(scenes.slider_yoke(elements=args.elements).natural_frequencies(args.count), 1):
            print(f"mode {i}: {fr:.3f} Hz")
    elif args.command == "compare":
        return _compare(args)
    elif args.command == "converge":
        return _converge(args)
    elif args.command == "montecarlo":
        return _montecarlo(args)
    elif args.command in ("spin-up", "slider-crank", "four-bar"):
        return _ked(args)
    return 0


def _ked(args) -> int:
    from .reports import mechanisms as kr

    def log(s: str) -> None:
        print(s, file=sys.stderr)

    if args.command == "spin-up":
        path = kr.spin_up_report(
            args.out,
            dt=args.dt,
            t_end=args.t_end,
            elements=args.elements,
            data=args.data,
            speeds=args.speeds,
            max_speed=args.max_speed,
            reference=args.reference,
            reference_flapwise=not args.reference_inplane,
            log=log,
        )
    elif args.command == "slider-crank":
        path = kr.slider_crank_report(
            args.out,
            dt=args.dt,
            t_end=args.t_end,
            elements=args.elements,
            clearance_at=args.clearance_at,
            clearance=args.clearance,
            method=args.method,
            log=log,
        )
    else:
        path = kr.four_bar_report(
            args.out,
            dt=args.dt,
            t_end=args.t_end,
            elements=args.elements,
            crank_speed=args.crank_speed,
            flexible_rocker=args.flexible_rocker,
            log=log,
        )
    print(path.read_text())
    print(f"report written to {path}", file=sys.stderr)
    return 0


def _accuracy(args) -> int:
    from .analysis.accuracy import write_report

    keys = None if args.scene == "all" else [args.scene]
    path = write_report(args.out, quick=args.quick, log=lambda s: print(s, file=sys.stderr), scene_keys=keys)
    print(path.read_text())
    print(f"report written to {path}", file=sys.stderr)
    return 0


def _montecarlo(args) -> int:
    from pathlib import Path

    from .errors import SimulationInterrupted
    from .study import load, write_report

    study = load(args.study)
    out = Path(args.out) if args.out else Path(Path(args.study).stem)
    client, cluster = None, None
    if args.scheduler or args.local_cluster:
        from dask.distributed import Client, LocalCluster

        if args.scheduler:
            client = Client(args.scheduler)
        else:
            cluster = LocalCluster(
                n_workers=args.local_cluster, threads_per_worker=1, dashboard_address=":0", host="127.0.0.1"
            )
            client = Client(cluster)
    try:
        result = study.run(
            store=out,
            threads=args.threads,
            lanes=args.lanes,
            chunk_size=args.chunk_size,
            client=client,
            progress=not args.no_progress,
        )
    except SimulationInterrupted as e:
        print(f"\n{e}; run the same command again to resume", file=sys.stderr)
        return 130
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    path = write_report(result, out, study.report_thresholds)
    if args.orbits > 0 and study.joints and len(result.ok):
        from .reports.orbits import orbit_section, plot_orbits

        png, rows = plot_orbits(result, out, count=args.orbits)
        with open(path, "a") as f:
            f.write("\n".join(["", *orbit_section(png, rows, study.joints[0])]))
    print(result.summary().to_string())
    print(f"{result!r}\nreport written to {path}", file=sys.stderr)
    _warn_unresolved(result)
    return 0


def _compare(args) -> int:
    from .analysis.distributions import compare, markdown, plot
    from .study import open_store

    a, b = open_store(args.a), open_store(args.b)
    table = compare(a, b, outputs=args.outputs, confidence=args.confidence, rtol=args.rtol)
    lines = [f"A = {args.a}, B = {args.b} (the reference)", "", *markdown(table, args.confidence, args.rtol)]
    if args.plots:
        paths = plot(table, a, b, args.plots, confidence=args.confidence, rtol=args.rtol)
        lines += ["", *(f"![{p.stem}]({p.resolve()})" for p in paths)]
    _emit(lines, args.out)
    return 0


def _converge(args) -> int:
    from .analysis.distributions import convergence
    from .study import load

    study = load(args.study)
    result = convergence(
        study,
        dts=args.dt,
        tols=args.tol,
        samples=args.samples,
        outputs=args.outputs,
        rtol=args.rtol,
        events=args.events,
        threads=args.threads,
        progress=lambda label: print(f"running {label}", file=sys.stderr),
    )
    lines = [f"{args.study}: {study.build}", "", *result.markdown()]
    if args.plots:
        lines += ["", *(f"![{p.stem}]({p.resolve()})" for p in result.plot(args.plots))]
    _emit(lines, args.out)
    return 0


def _emit(lines: list, out) -> None:
    """Prints a Markdown report's lines and, with ``out`` (a path), writes the same text there."""
    from pathlib import Path

    text = "\n".join(lines) + "\n"
    print(text, end="")
    if out:
        Path(out).write_text(text)


def _warn_unresolved(result) -> None:
    """Says on stderr which joints' contacts the fixed step leaves unresolved in some samples
    (:meth:`flexclear.study.StudyResult.unresolved`, as in the report's Resolution section)."""
    for sentence in result.unresolved():
        print(f"warning: {sentence} (report: Resolution)", file=sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
