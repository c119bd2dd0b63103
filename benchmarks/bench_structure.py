"""Structures: the two-mass chain, a Duffing oscillator, a 3-mass chain's modes, interval
coverage with a noisy force sensor, and PySINDy on the same records.

Rows: accuracy of equation-error on chain2 (1 kHz, 40 dB on the displacements, force known);
the identifiability verdict and its time; Duffing k3 and the output-error fit on a held-out
multisine (against the noise-free output: 40 dB noise alone caps a fit at 99 %); the modes of a
3-mass chain against the analytic eigenvalues; the coverage of the 95 % intervals over seeded
trials with 30 dB noise on the measured force (records in periodic steady state, and records
from rest with the start transient in them: ``--only=coverage-rest``); PySINDy (derivatives by
smoothed finite differences, linear library, force as control) on the same chain2 records,
error and time.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import physid  # noqa: E402
from physid.estimators import make  # noqa: E402
from physid.estimators.equation_error import fit_percent  # noqa: E402
from physid.models.library import model_from_spec  # noqa: E402
from physid.models.spec import parse_model_text  # noqa: E402
from test_equation_error_covariance import periodic_record  # noqa: E402
from test_modal import CHAIN3  # noqa: E402
from test_structure_estimation import DUFFING, chain_record  # noqa: E402

CHAIN2 = ROOT / "examples" / "models" / "chain2.toml"
#: The 3-mass chain of test_modal.CHAIN3 (m = 1.5 kg, k = 2000 N/m, c = 0.002 k) with every
#: mass, spring and damper its own parameter and every displacement measured.
CHAIN3_ALL = "\n".join(
    ['kind = "structure"', 'name = "chain3_all"', "[parameters]"]
    + [f'm{i} = {{ value = 1.5, unit = "kg" }}' for i in (1, 2, 3)]
    + [f'k{i} = {{ value = 2000.0, unit = "N/m" }}' for i in (1, 2, 3)]
    + [f'c{i} = {{ value = 4.0, unit = "N*s/m" }}' for i in (1, 2, 3)]
    + [f'[[masses]]\nname = "{n}"\nmass = "m{i}"' for i, n in enumerate("abc", 1)]
    + [
        f'[[{kind}s]]\nbetween = ["{a}", "{b}"]\n{what} = "{sym}{i}"'
        for kind, what, sym in (("spring", "stiffness", "k"), ("damper", "damping", "c"))
        for i, (a, b) in enumerate((("ground", "a"), ("a", "b"), ("b", "c")), 1)
    ]
    + ['[[forces]]\non = "a"\nchannel = "F"']
    + [f'[[outputs]]\ndisplacement = "{n}"' for n in "abc"]
)


def _row(case, value, unit, goal, met, **extra):
    return {
        "benchmark": "structure",
        "case": case,
        "value": value,
        "unit": unit,
        "goal": goal,
        "met": met,
        **extra,
    }


def _sindy(rec):
    """PySINDy on [x1, x2, v1, v2] with F as control; the physical parameters from M⁻¹K, M⁻¹C,
    M⁻¹B of the chain (B = [1, 0]: 1/m1 is the force's coefficient in ẍ1)."""
    import pysindy as ps

    t = rec.t
    x = rec.select(["x1", "x2"])
    diff = ps.SmoothedFiniteDifference()
    v = diff._differentiate(x, t)
    a = diff._differentiate(v, t)
    X = np.hstack([x, v])
    Xdot = np.hstack([v, a])
    model = ps.SINDy(
        feature_library=ps.PolynomialLibrary(degree=1, include_bias=False),
        optimizer=ps.STLSQ(threshold=0.0),
    )
    model.fit(X, t=t, x_dot=Xdot, u=rec["F"][:, None])
    coef = model.coefficients()[2:]  # rows ẍ1, ẍ2; columns x1 x2 v1 v2 F
    m1 = 1 / coef[0, 4]
    k2 = coef[0, 1] * m1
    k1 = -coef[0, 0] * m1 - k2
    c2 = coef[0, 3] * m1
    c1 = -coef[0, 2] * m1 - c2
    m2 = k2 / coef[1, 0]
    return {"m1": m1, "m2": m2, "k1": k1, "k2": k2, "c1": c1, "c2": c2}


def _chain_rows(quick):
    chain = physid.load_model(CHAIN2)
    truth = chain.parameters
    rows = []
    start = time.perf_counter()
    ident = chain.identifiability()
    rows.append(
        _row(
            "chain2 identifiability: seconds",
            time.perf_counter() - start,
            "s",
            "all six identifiable, < 2 s",
            ident.unidentifiable == () and time.perf_counter() - start < 2.0,
        )
    )
    seeds = range(3 if quick else 20)
    worst, inside, t_ee, worst_peer, t_peer = 0.0, 0, 0.0, 0.0, 0.0
    for seed in seeds:
        rec = chain_record(chain, 100 + seed)
        t0 = time.perf_counter()
        res = make("equation-error", chain).fit(rec).result_
        t_ee += time.perf_counter() - t0
        errs = [abs(res.parameters[k] / truth[k] - 1) for k in res.names]
        worst = max(worst, *errs)
        inside += all(lo <= truth[k] <= hi for k, (lo, hi) in res.confidence_intervals().items())
        t0 = time.perf_counter()
        peer = _sindy(rec)
        t_peer += time.perf_counter() - t0
        worst_peer = max(worst_peer, *[abs(peer[k] / truth[k] - 1) for k in truth])
    n = len(seeds)
    rows.append(
        _row(
            "chain2 40 dB: worst parameter error, equation-error",
            100 * worst,
            "%",
            "< 1 %",
            worst < 0.01,
            baseline="PySINDy",
            baseline_value=100 * worst_peer,
            ratio=worst_peer / worst,
        )
    )
    rows.append(
        _row(
            "chain2 40 dB: records with every truth in its 95 % interval",
            100 * inside / n,
            "%",
            f"~ {100 * 0.95**6:.0f} % (6 parameters)",
            None,
        )
    )
    rows.append(
        _row(
            "chain2: seconds per fit, equation-error",
            t_ee / n,
            "s",
            "-",
            None,
            baseline="PySINDy",
            baseline_value=t_peer / n,
            ratio=t_peer / t_ee,
        )
    )
    return rows


def _coverage_hits(seeds, from_rest=False):
    """Per seed: whether each parameter's 95 % interval holds the truth (30 dB on the force,
    40 dB on both displacements, 20 s of a multisine at 1 kHz: in its periodic steady state, or
    switched on at t = 0 with the structure at rest, the start transient in the record)."""
    chain = physid.load_model(CHAIN2)
    truth = chain.parameters
    record = chain_record if from_rest else periodic_record
    out = []
    for seed in seeds:
        res = make("equation-error", chain).fit(record(chain, seed, in_snr=30)).result_
        out.append([lo <= truth[k] <= hi for k, (lo, hi) in res.confidence_intervals().items()])
    return res.names, out


def _coverage_rest_hits(seeds):
    return _coverage_hits(seeds, from_rest=True)


def _coverage_rows(quick, from_rest=False):
    from concurrent.futures import ProcessPoolExecutor

    chain = physid.load_model(CHAIN2)
    trials = 20 if quick else 400
    seeds = [list(range(5000 + w, 5000 + trials, 2)) for w in range(2)]
    hits = _coverage_rest_hits if from_rest else _coverage_hits
    with ProcessPoolExecutor(2) as pool:  # the trials are independent: two processes
        parts = list(pool.map(hits, seeds))
    names = parts[0][0]
    cover = 100 * np.mean([h for _, hits in parts for h in hits], axis=0)
    record = "records from rest" if from_rest else "periodic records"
    rows = [
        _row(
            f"coverage, 30 dB on the force, {trials} trials, {record}: {k}",
            c,
            "%",
            "95 ± 3 %",
            abs(c - 95) <= 3,
        )
        for k, c in zip(names, cover, strict=True)
    ]
    if from_rest:
        return rows
    oe = make("output-error", chain).fit(chain_record(chain, 9, in_snr=30, duration=8.0)).result_
    rows.append(
        _row(
            "output-error with a noisy force: intervals withheld",
            float(oe.stderr is None),
            "bool",
            "withheld with the reason",
            oe.stderr is None,
        )
    )
    return rows


def _duffing_rows(quick):
    from physid.signals.excitation import multisine
    from physid.signals.recording import Recording
    from physid.simulate.structure import simulate_structure

    model = model_from_spec(parse_model_text(DUFFING))
    t = np.arange(0, 4 if quick else 6, 1e-3)
    omegas = 2 * np.pi * np.arange(0.5, 10.01, 0.5)
    recs = []
    for seed in (11, 12):
        rng = np.random.default_rng(seed)
        f = multisine(t, omegas, 1.0, phases=rng.uniform(0, 2 * np.pi, omegas.size))
        clean = simulate_structure(model, t, {"F": 10 * f / np.std(f)})
        data = clean.select(["F", "x"]).copy()
        data[:, 1] += rng.standard_normal(t.size) * np.std(data[:, 1]) * 0.01
        recs.append((Recording(t, data, ["F", "x"], ["N", "m"]), clean))
    rows = []
    for method in ("equation-error", "output-error"):
        t0 = time.perf_counter()
        res = make(method, model).fit(recs[0][0]).result_
        secs = time.perf_counter() - t0
        err = abs(res.parameters["k3"] / 1e5 - 1)
        fit = fit_percent(recs[1][1].select(["x"]), res.predict(recs[1][0]).select(["x"]))[0]
        rows.append(
            _row(f"Duffing k3 error, {method}", 100 * err, "%", "< 2 %", err < 0.02, seconds=secs)
        )
        rows.append(
            _row(
                f"Duffing held-out fit (vs noise-free), {method}", fit, "%", ">= 99 %", fit >= 99.0
            )
        )
    return rows


def _modal_rows():
    model = model_from_spec(parse_model_text(CHAIN3))
    j = np.arange(1, 4)
    omega = 2 * np.sqrt(2000 / 1.5) * np.sin((2 * j - 1) * np.pi / 14)
    modes = model.modal()
    err_w = np.max(np.abs(modes.frequency - omega) / omega)
    err_z = np.max(np.abs(modes.damping - 0.002 * omega / 2))
    return [
        _row(
            "3-mass chain: modal frequency error (relative)", err_w, "-", "<= 1e-9", err_w <= 1e-9
        ),
        _row("3-mass chain: damping ratio error", err_z, "-", "<= 1e-9", err_z <= 1e-9),
    ]


def _modal_hits(seeds):
    """Per seed: whether each mode's 95 % interval (delta method) of ω_j and ζ_j holds the
    analytic value; the 3-mass chain identified by equation-error, 40 dB on every
    displacement, the force known, 20 s periodic records at 1 kHz."""
    model = model_from_spec(parse_model_text(CHAIN3_ALL))
    j = np.arange(1, 4)
    omega = 2 * np.sqrt(2000 / 1.5) * np.sin((2 * j - 1) * np.pi / 14)
    zeta = 0.002 * omega / 2
    out = []
    for seed in seeds:
        modes = make("equation-error", model).fit(periodic_record(model, seed)).result_.modal()
        out.append(
            np.concatenate(
                [
                    np.abs(modes.frequency - omega) <= 1.959964 * modes.frequency_stderr,
                    np.abs(modes.damping - zeta) <= 1.959964 * modes.damping_stderr,
                ]
            )
        )
    return out


def _modal_coverage_rows(quick):
    from concurrent.futures import ProcessPoolExecutor

    trials = 20 if quick else 400
    seeds = [list(range(8000 + w, 8000 + trials, 2)) for w in range(2)]
    with ProcessPoolExecutor(2) as pool:
        hits = [h for part in pool.map(_modal_hits, seeds) for h in part]
    cover = 100 * np.mean(hits, axis=0)
    labels = [f"ω{j}" for j in (1, 2, 3)] + [f"ζ{j}" for j in (1, 2, 3)]
    return [
        _row(
            f"3-mass chain modes, 40 dB, {trials} trials: coverage of {lab}'s 95 % interval",
            c,
            "%",
            "95 ± 3 %",
            abs(c - 95) <= 3,
        )
        for lab, c in zip(labels, cover, strict=True)
    ]


def run(quick: bool = False, only: str | None = None) -> list[dict]:
    parts = {
        "modal": _modal_rows,
        "chain": lambda: _chain_rows(quick),
        "duffing": lambda: _duffing_rows(quick),
        "coverage": lambda: _coverage_rows(quick),
        "coverage-rest": lambda: _coverage_rows(quick, from_rest=True),
        "modal-coverage": lambda: _modal_coverage_rows(quick),
    }
    return [row for name, rows in parts.items() if only in (None, name) for row in rows()]


if __name__ == "__main__":
    only = next((a.split("=", 1)[1] for a in sys.argv if a.startswith("--only=")), None)
    for r in run(quick="--quick" in sys.argv, only=only):
        print(r)
