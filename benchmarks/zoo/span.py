"""The recipe on the time physid's rows cover: how much of a gap is the records' ends.

    PYTHONPATH=src python -m benchmarks.zoo.span [--cases e2,b]

physid's filters reach further than the recipe's: its state filter drops M = ⌈8π/Ω⌉ samples
at each end (four periods of its cut-off) and its parallel filter 12·nd more, where the recipe
drops 3/fc s. On a short record that starts with a fast transient, the ends the recipe keeps
can carry much of the inertial excitation. Per case this prints the recipe's held-out error
as in the zoo's table, then fitted only on the rows inside the span of physid's training rows,
and judged only on the rows inside the span of physid's held-out rows, next to physid's
default: the same comparison on the same stretch of each record.
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

import physid
from physid.estimators import make
from physid.signals.joint_side import joint_side

from . import cases, compare
from .recipe import Recipe, relative_error


def span_row(case) -> dict:
    """Held-out errors of the recipe (whole record / physid's span) and of physid's default."""
    recipe = Recipe(case.urdf, armature=case.armature, offset=case.offset)
    cut = 5.0 * case.bandwidth_hz
    model = physid.load_model(case.physid_model)
    train = joint_side(model, case.physid_train) if case.physid_train is not None else case.train
    test = joint_side(model, case.physid_test) if case.physid_test is not None else case.test
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = make(compare.DEFAULT_METHOD, model).fit(train)
    res = est.result_
    pred = res.predict(test, measured=True)
    nj = recipe.nj
    P = np.asarray(pred.select([f"tau{j + 1}" for j in range(nj)]))
    physid_err = relative_error(P, compare._target_at(case, cut, recipe, pred.t))[0]
    fit_span = (float(est.rows_.t[0]), float(est.rows_.t[-1]))
    test_span = (float(pred.t[0]), float(pred.t[-1]))

    def recipe_err(fit, judged_span=None):
        t, tau_hat, _ = recipe.predict(fit, case.test)
        target = compare._target_at(case, cut, recipe, t)
        keep = np.ones(t.size, bool) if judged_span is None else (
            (t >= judged_span[0]) & (t <= judged_span[1])
        )  # fmt: skip
        return relative_error(tau_hat[keep], target[keep])[0]

    whole = recipe.fit(case.train, cut)
    inside = recipe.fit(case.train, cut, span=fit_span)
    rows = recipe.rows(case.train, cut)
    return {
        "case": case.key,
        "recipe_span": (float(rows.t[0]), float(rows.t[-1])),
        "physid_span": fit_span,
        "recipe": recipe_err(whole),
        "recipe_on_physid_span": recipe_err(inside),
        "recipe_on_physid_spans": recipe_err(inside, test_span),
        "physid": physid_err,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--cases", default="e2", help=f"comma-separated, from {','.join(cases.BUILDERS)}"
    )
    args = ap.parse_args(argv)
    keys = [k.strip() for k in args.cases.split(",") if k.strip()]
    unknown = set(keys) - set(cases.BUILDERS)
    if unknown:
        ap.error(f"unknown case(s) {sorted(unknown)}; known: {list(cases.BUILDERS)}")
    print(
        "| case | recipe's training rows [s] | physid's [s] | recipe held-out | recipe fitted in "
        "physid's span | also judged in physid's held-out span | physid default |\n"
        "|---|---|---|---|---|---|---|"
    )
    for case in cases.build(keys):
        if case.skipped:
            print(f"| {case.key} | skipped: {case.skipped} | | | | | |")
            continue
        r = span_row(case)
        print(
            f"| {r['case']} | {r['recipe_span'][0]:.2f}–{r['recipe_span'][1]:.2f} "
            f"| {r['physid_span'][0]:.2f}–{r['physid_span'][1]:.2f} | {r['recipe']:.4g} "
            f"| {r['recipe_on_physid_span']:.4g} | {r['recipe_on_physid_spans']:.4g} "
            f"| {r['physid']:.4g} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
