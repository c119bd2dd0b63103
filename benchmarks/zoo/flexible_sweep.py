"""Case (h) swept: physid's IDIM at its automatic and at fixed state-filter cut-offs, per base
parameter, and the motor-angle spectrum against a stiff twin.

    PYTHONPATH=src python -m benchmarks.zoo.flexible_sweep [--scale 1] [--ripple 0] [--spectrum]

``--scale`` multiplies the joint stiffness (1e4: modes at 1.7 and 3.1 kHz, a rigid arm for
this sampling); ``--ripple`` [A] adds a white current the drives carry (it excites the joint
modes); ``--spectrum`` prints the Welch spectrum of the motor angles qm in bands, in dB above
their floor (median over 1–2.4 kHz) and against the same record with 10^4 times stiffer joints.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from scipy.signal import welch

import physid
from physid.estimators import make
from physid.signals.joint_side import joint_side

from . import cases, compare
from .recipe import Recipe

FIXED_HZ = (2.5, 5.0, 10.0, 20.0, 50.0, 100.0)
BANDS = (2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 25, 28, 31, 34, 38, 45, 60, 80, 120, 200, 400, 800)


def sweep(scale, ripple):
    """The zoo's table for case (h) and each method's relative error per nonzero base parameter."""
    case = cases.case_flexible_arm(stiffness_scale=scale, ripple=ripple)
    fs = 1.0 / case.train.dt
    cuts = [f"cutoff={2 * np.pi * f / fs:.6g}" for f in FIXED_HZ]
    methods = ["idim-ols", "idim-ols:stick_threshold=0"]
    methods += [f"idim-ols:{c}" for c in cuts] + [f"idim-ols:{c},stick_threshold=0" for c in cuts]
    outs, _ = compare.run_case(case, methods)
    print(f"scale {scale:g}, ripple {ripple:g} A; {case.note}\n")
    print(
        "| method | cut-off | held-out | base-param err (n well) | success |\n|---|---|---|---|---|"
    )
    for o in outs:
        print(f"| {o.method} | {o.cutoff} | {o.heldout:.4g} | {o.param_error:.3g} ({o.n_well}) "
              f"| {o.success} |")  # fmt: skip
    recipe = Recipe(case.urdf, armature=True)
    truth = recipe.truth(case.truth)
    nz = np.abs(truth) > 1e-9
    names = [n for n, k in zip(recipe.base_names, nz, strict=True) if k]
    print("\nrelative error per base parameter\n\n| method | " + " | ".join(names) + " |")
    print("|---" * (len(names) + 1) + "|")

    def row(label, beta):
        rel = (beta[nz] - truth[nz]) / truth[nz]
        print(f"| {label} | " + " | ".join(f"{x:+.3f}" for x in rel) + " |")

    row("recipe", recipe.fit(case.train, 5.0 * case.bandwidth_hz).beta)
    model = physid.load_model(case.physid_model)
    train = joint_side(model, case.physid_train)
    for m in methods:
        name, settings = compare.parse_method(m)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = make(name, model, **settings).fit(train).result_
        beta, _ = compare._physid_in_recipe_base(model, res, recipe)
        row(f"{m} ({res.cutoff * fs / (2 * np.pi):.3g} Hz)", beta)


def spectrum(scale, ripple):
    """qm's Welch spectrum per band: dB above its floor, and dB above a 10^4 times stiffer twin."""
    spec = {}
    for s in (scale, 1e4 * scale):
        c = cases.case_flexible_arm(train_s=20.0, test_s=0.5, stiffness_scale=s, ripple=ripple)
        qm = np.asarray(c.physid_train.select(["qm1", "qm2"]))
        f, p = welch(qm - qm.mean(0), fs=1.0 / c.train.dt, nperseg=2**13, axis=0)
        spec[s] = p, np.median(p[(f > 1000) & (f < 2400)], axis=0)
    (p, floor), (pst, _) = spec[scale], spec[1e4 * scale]
    print(f"\nqm spectrum, scale {scale:g}, ripple {ripple:g} A (Welch, 0.61 Hz bins)\n")
    print("| band [Hz] | qm1 dB re floor | qm1 − stiff [dB] | qm2 dB re floor | qm2 − stiff [dB] |")
    print("|---|---|---|---|---|")
    for lo, hi in zip(BANDS[:-1], BANDS[1:], strict=True):
        m = (f >= lo) & (f < hi)
        cells = []
        for j in range(2):
            cells += [
                10 * np.log10(p[m, j].mean() / floor[j]),
                10 * np.log10(p[m, j].mean() / pst[m, j].mean()),
            ]
        print(f"| {lo}–{hi} | " + " | ".join(f"{x:.1f}" for x in cells) + " |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0, help="joint stiffness multiplier")
    ap.add_argument("--ripple", type=float, default=0.0, help="σ of a drive current ripple [A]")
    ap.add_argument("--spectrum", action="store_true", help="the qm spectrum only")
    args = ap.parse_args(argv)
    if args.spectrum:
        spectrum(args.scale, args.ripple)
    else:
        sweep(args.scale, args.ripple)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
