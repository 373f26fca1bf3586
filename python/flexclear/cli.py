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
    args = parser.parse_args(argv)
    if args.command == "paper":
        from .paper import write_report

        path = write_report(args.out, fig6_t_end=args.fig6_t_end, log=lambda s: print(s, file=sys.stderr))
        print(path.read_text())
        print(f"report written to {path}", file=sys.stderr)
    elif args.command == "frequencies":
        from . import scenes

        for i, fr in enumerate(scenes.slider_yoke(elements=args.elements).natural_frequencies(args.count), 1):
            print(f"mode {i}: {fr:.3f} Hz")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
