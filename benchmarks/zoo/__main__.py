"""Print the zoo's table (markdown): ``python -m benchmarks.zoo [--quick] [--cases a,b,e1]``.

Also runs as ``python benchmarks/zoo/__main__.py``. Progress goes to stderr, the table to stdout.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a script: import the package from its folder's parent
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from zoo import cases, compare
else:
    from . import cases, compare


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="one short simulated case, OLS and WLS")
    p.add_argument("--cases", default="", help=f"comma-separated, from {','.join(cases.BUILDERS)}")
    p.add_argument(
        "--methods",
        default="",
        help=f"comma-separated physid methods (default: {','.join(compare.METHODS)})",
    )
    p.add_argument("--no-cli", action="store_true", help="skip the `physid identify` cross-check")
    args = p.parse_args(argv)
    keys = [k.strip() for k in args.cases.split(",") if k.strip()] or None
    unknown = set(keys or ()) - set(cases.BUILDERS)
    if unknown:
        p.error(f"unknown case(s) {sorted(unknown)}; known: {list(cases.BUILDERS)}")
    # a comma separates methods, and a method's settings too: a new method starts at a name
    # followed by ":", "," or the end ("idim-ols:decimate=10,cutoff=4,idim-wls")
    methods = (
        tuple(m.strip() for m in re.split(r",(?=[a-z][a-z-]*(?::|,|$))", args.methods) if m.strip())
        or None
    )
    outcomes, facts = compare.run(
        quick=args.quick,
        keys=keys,
        methods=methods,
        cli=False if args.no_cli else None,
        log=lambda s: print(s, file=sys.stderr, flush=True),
    )
    print(compare.markdown(outcomes, facts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
