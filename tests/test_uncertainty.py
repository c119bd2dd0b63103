"""Standard errors of the algebraic and recursive estimators against a seeded Monte Carlo.

The full coverage study (400 trials, 30/60 dB, two MSDs) is benchmarks/bench_coverage.py; here
25 noise draws on one short record check that the reported standard error matches the spread of
the estimates (within the Monte-Carlo uncertainty of a 25-sample standard deviation, ±30 %).
"""

from __future__ import annotations

import numpy as np
import pytest

from physid.estimators import make
from physid.simulate.msd import msd_paper_scenario

TRIALS = 25


@pytest.mark.parametrize(
    ("method", "options"),
    [("algebraic", {}), ("algebraic", {"final": "bias-compensated"}), ("rls", {})],
)
def test_stderr_matches_monte_carlo_spread(method, options):
    errors, stderrs = [], []
    for seed in range(TRIALS):
        rec = msd_paper_scenario(1.0, 50, duration=2.0, seed=seed, damping_ratio=0.3)
        res = make(method, "msd", **options).fit(rec).result_
        assert res.success
        if method == "algebraic" and not options and res.stderr is None:
            # wave 3: the default withholds where it lies > 1 se from the bias-compensated
            # estimate (5 of these 25 records); the ratio is over the intervals it gives
            assert "final='bias-compensated'" in res.stderr_reason
            continue
        assert res.stderr is not None
        errors.append([res.parameters[k] - rec.metadata[k] for k in ("theta1", "theta2")])
        stderrs.append([res.stderr[k] for k in ("theta1", "theta2")])
    assert len(errors) >= 15
    ratio = np.std(errors, axis=0, ddof=1) / np.mean(stderrs, axis=0)
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio


def test_median_final_has_no_stderr_and_says_why():
    rec = msd_paper_scenario(1.0, 50, duration=2.0, seed=0, damping_ratio=0.3)
    res = make("algebraic", "msd", final="median").fit(rec).result_
    assert res.stderr is None and "median" in res.stderr_reason
    assert "no standard errors" in res.summary()


def test_bias_compensation_removes_the_low_snr_bias():
    """At 30 dB and T = 0.05 s the default final estimate of θ2 is biased by ~1 %
    (5 standard deviations); the bias-compensated one is not."""
    rel = {"lstsq": [], "bias-compensated": []}
    for seed in range(10):
        rec = msd_paper_scenario(1.0, 30, seed=seed)
        for final in rel:
            res = make("algebraic", "msd", final=final).fit(rec).result_
            rel[final].append(res.parameters["theta2"] / rec.metadata["theta2"] - 1)
    assert abs(np.mean(rel["lstsq"])) > 5e-3
    assert abs(np.mean(rel["bias-compensated"])) < 1e-3
