"""``physid demo [--out DIR] [--quick]``: reproduce both papers, identify a 6-DOF arm, write the
HTML report."""

from __future__ import annotations

import argparse

from ._common import progress

ORDER = 10
#: Library keyword → this verb's flag, for error messages (physid.errors.arg).
ARGUMENT_FLAGS = {"out_dir": "--out"}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="reproduce both papers and identify a 6-DOF arm on built-in data; write DIR/report.html",
        description=(
            "Reproduce two papers on built-in, simulated data (Cedro & Janecki: input-error "
            "identification of a 4-DOF manipulator; Oueslati et al.: algebraic vs recursive "
            "estimation of a mass-spring-damper), identify a 6-DOF arm end to end, and write one "
            "self-contained report: DIR/report.html (figures embedded), DIR/results.json (every "
            "number) and the figures as PNG files. The outputs are staged beside DIR and moved "
            "in at the end, so an interrupted demo leaves DIR as it was. Progress goes to "
            "stderr; the report's path is printed on stdout."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        default="demo-out",
        help="output folder (created if missing; the demo's files in it are replaced)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="short records, small grids and fewer seeds: under a minute",
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    from ..report.demo import check_out_dir, run_demo

    check_out_dir(args.out)  # before any work: a bad --out must not cost a whole demo
    paths = run_demo(args.out, quick=args.quick, progress=progress)
    print(paths.html)
    return 0
