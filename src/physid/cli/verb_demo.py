"""``physid demo [--out DIR] [--quick]``: reproduce both papers and write the HTML report."""

from __future__ import annotations

import argparse

from ._common import progress

ORDER = 10


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="reproduce both papers on built-in data and write DIR/report.html",
        description=(
            "Reproduce both papers on built-in, simulated data (seed 000: input-error "
            "identification of a 4-DOF manipulator; seed 003: algebraic vs recursive estimation "
            "of a mass-spring-damper) and write one self-contained report: DIR/report.html "
            "(figures embedded), DIR/results.json (every number) and the figures as PNG files. "
            "Progress goes to stderr; the report's path is printed on stdout."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        default="demo-out",
        help="output folder (created if missing; files in it are replaced)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="short records and small grids: under a minute on two cores",
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    from ..experiments.demo import run_demo

    paths = run_demo(args.out, quick=args.quick, progress=progress)
    print(paths.html)
    return 0
