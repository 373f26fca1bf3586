"""The long fuzz campaign of issue 18 (outside CI): random models, scenes, recording choices and
study definitions through flexclear's public API, each case in a worker process with a time and a
memory limit.

    PYTHONPATH=$PWD/python python scripts/fuzz.py --cases 10000 --seed 1 --jobs 2

Prints the counts by outcome class (ok, flexclear_error, foreign_exception, nan, crash, hang) and
writes every failing case (its parameters as JSON, with the outcome) to ``--out``, one per line;
rerun one with ``--replay FILE`` (all of them) or ``--case SEED:INDEX``. ``--minutes`` stops
early after that much wall time (the cases done are reported). Exit status 1 when any case
failed.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from fuzz.harness import FAILURES, KNOWN, OUTCOMES, Pool, generate  # noqa: E402


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", type=int, default=10000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--first", type=int, default=0, help="index of the first case")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--timeout", type=float, default=60.0, help="seconds per case")
    p.add_argument("--memory", type=float, default=4.0, help="GiB of address space per worker")
    p.add_argument("--minutes", type=float, default=None, help="stop after this much wall time")
    p.add_argument("--out", default="fuzz-failures.jsonl", help="where the failing cases go")
    p.add_argument("--log", default=None, help="also write every outcome here (JSON lines)")
    p.add_argument("--replay", default=None, help="rerun the cases of a failures file")
    p.add_argument("--case", default=None, help="rerun one case, SEED:INDEX")
    args = p.parse_args(argv)

    if args.replay:
        cases = [json.loads(line)["case"] for line in Path(args.replay).read_text().splitlines() if line]
    elif args.case:
        seed, index = (int(x) for x in args.case.split(":"))
        cases = [generate(seed, index)]
    else:
        cases = [generate(args.seed, i) for i in range(args.first, args.first + args.cases)]
    pool = Pool(jobs=args.jobs, timeout=args.timeout, memory=int(args.memory * 2**30))
    deadline = None if args.minutes is None else time.monotonic() + 60 * args.minutes
    counts: collections.Counter = collections.Counter()
    kinds: collections.Counter = collections.Counter()
    t0 = time.monotonic()
    failures = open(args.out, "w")
    log = open(args.log, "w") if args.log else None
    stopped = False
    it = pool.map(cases)
    try:
        for case, outcome in it:
            counts[outcome["outcome"]] += 1
            if outcome.get("known"):
                counts["known:" + outcome["known"]] += 1
            kinds[(case["kind"], outcome["outcome"])] += 1
            row = json.dumps({"id": case["id"], **outcome, "case": case})
            if log:
                log.write(row + "\n")
            if outcome["outcome"] in FAILURES:
                failures.write(row + "\n")
                failures.flush()
                print(
                    f"{outcome['outcome']}: {case['id']} {outcome.get('type', '')}: "
                    f"{str(outcome.get('detail', ''))[:200]}",
                    flush=True,
                )
            done = sum(counts[k] for k in OUTCOMES)
            if done % 500 == 0:
                print(f"[{done}/{len(cases)} in {time.monotonic() - t0:.0f} s] {dict(counts)}", flush=True)
            if deadline is not None and time.monotonic() > deadline:
                stopped = True
                break
    except KeyboardInterrupt:
        stopped = True
    finally:
        failures.close()
        if log:
            log.close()
        if stopped:
            for w in pool.workers:
                w.stop()
    wall = time.monotonic() - t0
    total = sum(counts[k] for k in OUTCOMES)
    print(f"\n{total} cases (seed {args.seed}) in {wall:.0f} s{' (stopped early)' if stopped else ''}")
    for k in OUTCOMES:
        print(f"  {k:18s} {counts.get(k, 0)}")
    for key in KNOWN:
        if counts.get("known:" + key):
            print(f"  of which known ({key}): {counts['known:' + key]}")
    print("by kind: " + ", ".join(f"{k}/{o}={n}" for (k, o), n in sorted(kinds.items())))
    bad = sum(counts.get(k, 0) for k in FAILURES)
    known = sum(counts.get("known:" + k, 0) for k in KNOWN)
    print(f"failing cases: {bad}, {known} of them known (written to {args.out})")
    bad -= known
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
