#!/usr/bin/env python
"""Run physid's benchmarks and print one table (``--json`` prints the rows as JSON).

Each ``benchmarks/bench_*.py`` defines ``run(quick: bool) -> list[dict]``; a row has the keys
``benchmark``, ``case``, ``value``, ``unit``, and where it applies ``baseline`` (what we compare
with, measured in the same run), ``baseline_value``, ``ratio`` (how many times better we are, >1
is better), ``goal`` (text) and ``met`` (bool). ``--quick`` runs a small subset so CI keeps the
benchmarks from rotting; timings from it are not meant to be quoted.

Usage: python benchmarks/run.py [--quick] [--json] [--only NAME[,NAME]]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _load(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    # registered under its name, so that worker processes of a benchmark (a process pool)
    # can pickle its functions by reference and import the module themselves
    sys.modules[path.stem] = mod
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    spec.loader.exec_module(mod)
    return mod


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "NO"
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        return f"{v:.4g}"
    return str(v)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="small sizes, for CI")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.add_argument("--only", default="", help="comma-separated bench module names (e.g. filters)")
    args = p.parse_args(argv)
    only = {s.strip() for s in args.only.split(",") if s.strip()}
    rows = []
    failed = []
    for path in sorted(HERE.glob("bench_*.py")):
        name = path.stem.removeprefix("bench_")
        if only and name not in only:
            continue
        print(f"[bench] {name} ...", file=sys.stderr, flush=True)
        start = time.perf_counter()
        try:
            mod_rows = _load(path).run(quick=args.quick)
        except Exception as exc:  # a broken benchmark must fail CI, loudly
            failed.append(f"{name}: {type(exc).__name__}: {exc}")
            continue
        for r in mod_rows:
            r.setdefault("benchmark", name)
        rows.extend(mod_rows)
        print(
            f"[bench] {name} done in {time.perf_counter() - start:.1f} s",
            file=sys.stderr,
            flush=True,
        )
    if args.json:
        json.dump(rows, sys.stdout, indent=2, default=str)
        print()
    else:
        cols = [
            "benchmark",
            "case",
            "value",
            "unit",
            "baseline",
            "baseline_value",
            "ratio",
            "goal",
            "met",
        ]
        table = [[_fmt(r.get(c)) for c in cols] for r in rows]
        widths = [
            max(len(c), *(len(row[i]) for row in table)) if table else len(c)
            for i, c in enumerate(cols)
        ]
        print("  ".join(c.ljust(w) for c, w in zip(cols, widths, strict=True)))
        print("  ".join("-" * w for w in widths))
        for row in table:
            print("  ".join(v.ljust(w) for v, w in zip(row, widths, strict=True)))
    if failed:
        print("benchmarks that failed to run:\n  " + "\n  ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
