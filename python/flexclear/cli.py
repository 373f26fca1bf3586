"""The ``flexclear`` command line."""

from __future__ import annotations

import argparse
import sys
from typing import Optional


def main(argv: Optional[list] = None) -> int:
    parser = argparse.ArgumentParser(prog="flexclear", description=__doc__)
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
    mc.add_argument("--chunk-size", type=int, default=None, help="samples per Parquet part / Dask task")
    mc.add_argument("--scheduler", default=None, help="address of a Dask scheduler to run on")
    mc.add_argument(
        "--local-cluster", type=int, default=0, metavar="N", help="start a local Dask cluster of N workers"
    )
    mc.add_argument("--no-progress", action="store_true", help="no progress bar")
    ac = sub.add_parser(
        "accuracy", help="speed/accuracy of the contact couplings: Pareto fronts and a recommendation"
    )
    ac.add_argument("--out", default="flexclear-accuracy", help="output folder (default: %(default)s)")
    ac.add_argument("--quick", action="store_true", help="CI-sized sweep (about a minute)")
    args = parser.parse_args(argv)
    if args.command == "accuracy":
        return _accuracy(args)
    if args.command == "paper":
        from .paper import write_report

        path = write_report(args.out, fig6_t_end=args.fig6_t_end, log=lambda s: print(s, file=sys.stderr))
        print(path.read_text())
        print(f"report written to {path}", file=sys.stderr)
    elif args.command == "frequencies":
        from . import scenes

        for i, fr in enumerate(scenes.slider_yoke(elements=args.elements).natural_frequencies(args.count), 1):
            print(f"mode {i}: {fr:.3f} Hz")
    elif args.command == "montecarlo":
        return _montecarlo(args)
    return 0


def _accuracy(args) -> int:
    from .accuracy import write_report

    path = write_report(args.out, quick=args.quick, log=lambda s: print(s, file=sys.stderr))
    print(path.read_text())
    print(f"report written to {path}", file=sys.stderr)
    return 0


def _montecarlo(args) -> int:
    from pathlib import Path

    from .errors import FlexclearError, SimulationInterrupted
    from .study import load, write_report

    try:
        study = load(args.study)
    except FlexclearError as e:
        print(f"flexclear montecarlo: error: {e}", file=sys.stderr)
        return 2
    out = Path(args.out) if args.out else Path(Path(args.study).stem)
    client, cluster = None, None
    if args.scheduler or args.local_cluster:
        from dask.distributed import Client, LocalCluster

        if args.scheduler:
            client = Client(args.scheduler)
        else:
            cluster = LocalCluster(
                n_workers=args.local_cluster, threads_per_worker=1, dashboard_address=None, host="127.0.0.1"
            )
            client = Client(cluster)
    try:
        result = study.run(
            store=out,
            threads=args.threads,
            chunk_size=args.chunk_size,
            client=client,
            progress=not args.no_progress,
        )
    except SimulationInterrupted as e:
        print(f"\n{e}; run the same command again to resume", file=sys.stderr)
        return 130
    except FlexclearError as e:
        print(f"flexclear montecarlo: error: {e}", file=sys.stderr)
        return 2
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    path = write_report(result, out, study.report_thresholds)
    print(result.summary().to_string())
    print(f"{result!r}\nreport written to {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
