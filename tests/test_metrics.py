"""Convergence metrics on synthetic error traces whose answers are known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from physid.analysis import metrics
from physid.errors import InputError, SamplingError, ShapeError

DT = 1e-3


def _time(duration=2.0):
    return np.arange(int(round(duration / DT)) + 1) * DT


# --------------------------------------------------------------------------- first hit
def test_first_hit_of_exponential_decay_matches_closed_form():
    # est = truth (1 + e0 exp(-t / tau)): relative error e0 exp(-t/tau) < 0.02 first for
    # t > tau ln(e0 / 0.02); the first sample after that instant is the answer.
    t = _time()
    truth, e0, tau = 11.547, 0.5, 0.2
    est = truth * (1 + e0 * np.exp(-t / tau))
    t_star = tau * math.log(e0 / 0.02)
    expected = t[np.searchsorted(t, t_star, side="right")]
    assert metrics.first_hit_time(t, est, truth) == pytest.approx(expected, abs=1e-12)
    assert abs(expected - t_star) <= DT


def test_first_hit_skips_nan_and_invalid_samples_and_is_nan_when_never_reached():
    t = _time(0.01)
    est = np.full(t.size, 2.0)
    est[3] = 1.0  # right, but flagged invalid
    est[5] = np.nan
    est[7] = 1.01
    valid = np.ones(t.size, bool)
    valid[3] = False
    assert metrics.first_hit_time(t, est, 1.0, valid=valid) == pytest.approx(t[7])
    assert metrics.first_hit_time(t, est, 1.0, valid=valid, invalid="fail") == pytest.approx(t[7])
    assert metrics.first_hit_time(t, est, 1.0) == pytest.approx(t[3])
    assert math.isnan(metrics.first_hit_time(t, np.full(t.size, 3.0), 1.0))
    # the clock can start elsewhere (e.g. at a jump)
    assert metrics.first_hit_time(t, est, 1.0, t_start=t[2]) == pytest.approx(t[3] - t[2])


# --------------------------------------------------------------------------- settle
def _slow_settle(ok, length, fraction):
    """Literal reference: try every start, check every later full stretch."""
    n = ok.size
    needed = math.ceil(fraction * length - 1e-9)
    for start in range(0, n - length + 1):
        if ok[start] and all(
            ok[j : j + length].sum() >= needed for j in range(start, n - length + 1)
        ):
            return start
    return None


def test_settle_ignores_isolated_spikes_but_not_a_burst():
    t = _time(3.0)
    truth = 2.0
    est = np.full(t.size, truth)
    est[:1000] = 3.0  # wrong for the first second
    # isolated spikes every 20 samples after 1 s: at most 5 per 100-sample stretch = 95 % kept
    est[1000::20] = 3.0
    assert metrics.first_hit_time(t, est, truth) == pytest.approx(t[1001])
    assert metrics.settle_time(t, est, truth) == pytest.approx(t[1001], abs=1e-12)
    # a burst of 6 bad samples starting at b: every stretch holding all 6 (starts b-94 .. b) fails,
    # and the clock restarts at the first good sample after it: t[b + 6]
    b = 2003
    est2 = np.full(t.size, truth)
    est2[:1000] = 3.0
    est2[b : b + 6] = 3.0
    assert metrics.settle_time(t, est2, truth) == pytest.approx(t[b + 6], abs=1e-12)
    # every 19th sample: some stretches hold 6 spikes, so it never settles before the last such
    est3 = np.full(t.size, truth)
    est3[::19] = 3.0
    ok = metrics.within_tolerance(est3, truth)
    ref = _slow_settle(ok, 100, 0.95)
    got = metrics.settle_time(t, est3, truth)
    assert (ref is None and math.isnan(got)) or got == pytest.approx(t[ref])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_settle_equals_literal_loop_on_random_traces(seed):
    rng = np.random.default_rng(seed)
    n = 400
    t = np.arange(n) * DT
    # error falls below 2 % on average after ~150 samples, with random excursions
    err = 0.05 * np.exp(-np.arange(n) / 60.0) + rng.uniform(0, 0.02, n) * (rng.random(n) < 0.9)
    err[rng.random(n) < 0.03] = 0.5
    est = 5.0 * (1 + err)
    ok = metrics.within_tolerance(est, 5.0)
    for length, fraction in [(20, 0.95), (50, 0.9), (10, 1.0)]:
        ref = _slow_settle(ok, length, fraction)
        got = metrics.settle_time(t, est, 5.0, stretch=length * DT, fraction=fraction)
        if ref is None:
            assert math.isnan(got)
        else:
            assert got == pytest.approx(t[ref], abs=1e-12)


def test_invalid_samples_hold_the_last_valid_estimate_or_fail():
    t = _time(1.0)
    est = np.ones(t.size)
    valid = np.ones(t.size, bool)
    valid[::10] = False  # 10 % of the windows rejected by a guard, their values garbage
    est[::10] = 50.0
    assert metrics.settle_time(t, est, 1.0, valid=valid) == pytest.approx(t[1])
    assert math.isnan(metrics.settle_time(t, est, 1.0, valid=valid, invalid="fail"))
    assert math.isnan(metrics.settle_time(t, est, 1.0))  # without flags the garbage counts
    held = metrics.hold_last_valid(est, valid)
    assert np.all(held[1:] == 1.0) and math.isnan(held[0])
    with pytest.raises(InputError, match="invalid must be 'hold' or 'fail'"):
        metrics.within_tolerance(est, 1.0, 0.02, valid, invalid="skip")


def test_settle_is_nan_when_the_end_is_bad_or_the_record_too_short():
    t = _time(1.0)
    est = np.ones(t.size)
    est[-50:] = 2.0
    assert math.isnan(metrics.settle_time(t, est, 1.0))
    t_short = np.arange(50) * DT
    assert math.isnan(metrics.settle_time(t_short, np.ones(50), 1.0))  # 50 samples < 100 ms
    assert metrics.settle_time(t, np.ones(t.size), 1.0) == 0.0


def test_convergence_times_reports_final_error_of_last_valid_sample():
    t = _time(1.0)
    est = np.full(t.size, 1.01)
    est[-1] = 5.0
    valid = np.ones(t.size, bool)
    valid[-1] = False
    out = metrics.convergence_times(t, est, 1.0, valid=valid)
    assert out["final_error"] == pytest.approx(0.01)
    assert out["first_hit"] == 0.0


# --------------------------------------------------------------------------- recovery after jumps
def test_recovery_times_after_each_jump_match_first_order_lag():
    t = _time(3.0)
    jumps = [1.0, 2.0]
    levels = [10.0, 14.0, 8.0]
    tau = 0.05
    truth = np.select([t < 1.0, t < 2.0], levels[:2], levels[2])
    est = np.full(t.size, levels[0])
    for k, tj in enumerate(jumps):
        after = t >= tj
        est[after] = levels[k + 1] + (levels[k] - levels[k + 1]) * np.exp(-(t[after] - tj) / tau)
    rec = metrics.recovery_times(t, est, truth, jumps)
    assert rec["first_hit"][0] == 0.0
    for k in range(2):
        rel = abs(levels[k] - levels[k + 1]) / levels[k + 1]
        t_star = tau * math.log(rel / 0.02)
        assert rec["first_hit"][k + 1] == pytest.approx(t_star, abs=DT)
        # a monotone lag settles exactly when it first hits (settle starts at a good sample)
        assert rec["settle"][k + 1] == pytest.approx(rec["first_hit"][k + 1], abs=1e-12)
    np.testing.assert_allclose(rec["truth"], levels)
    with pytest.raises(InputError, match="change_times must be increasing"):
        metrics.recovery_times(t, est, truth, [2.0, 1.0])


# --------------------------------------------------------------------------- shortest window
class _FakeResult:
    def __init__(self, t, values, valid):
        self.t, self.natural_frequency, self.valid = t, values, valid


class _FakeWindowEstimator:
    """Estimate = truth (1 + c / T) on full windows (NaN before); every 10th window flagged invalid
    when ``invalid_every`` is set. Within 2 % iff c / T < 0.02, i.e. T > 50 c."""

    def __init__(self, window, c=0.001, truth=10.0, invalid_every=None):
        self.window, self.c, self.truth, self.invalid_every = window, c, truth, invalid_every

    def fit(self, rec):
        t = rec
        values = np.where(t >= self.window - 1e-12, self.truth * (1 + self.c / self.window), np.nan)
        valid = np.ones(t.size, bool)
        if self.invalid_every:
            valid[:: self.invalid_every] = False
        self.result_ = _FakeResult(t, values, valid)
        return self


def test_shortest_window_finds_the_analytic_threshold():
    t = _time(1.0)
    windows = [0.01, 0.03, 0.049, 0.051, 0.08]
    res = metrics.shortest_window(lambda T: _FakeWindowEstimator(T), t, windows, 10.0)
    # c = 0.001: within 2 % iff T > 0.05
    assert res.shortest == pytest.approx(0.051)
    np.testing.assert_array_equal(res.fraction_within, [0, 0, 0, 1, 1])
    assert res.success
    # 10 % invalid windows counted as failures: never 95 % within
    res2 = metrics.shortest_window(
        lambda T: _FakeWindowEstimator(T, invalid_every=10), t, windows, 10.0, invalid="fail"
    )
    assert math.isnan(res2.shortest) and not res2.success
    assert res2.fraction_within[-1] == pytest.approx(0.9, abs=0.002)
    assert "try longer windows" in res2.message
    # ... but holding the last valid estimate (the default) the user is within 2 % all the time
    res3 = metrics.shortest_window(
        lambda T: _FakeWindowEstimator(T, invalid_every=10), t, windows, 10.0
    )
    assert res3.shortest == pytest.approx(0.051)


def test_shortest_window_records_a_window_the_estimator_rejects():
    t = _time(0.5)

    def factory(T):
        if T < 0.02:
            raise SamplingError("window too short for the kernel")
        return _FakeWindowEstimator(T)

    res = metrics.shortest_window(factory, t, [0.01, 0.06], 10.0)
    assert math.isnan(res.fraction_within[0]) and "too short" in res.errors[0]
    assert res.shortest == pytest.approx(0.06)
    with pytest.raises(InputError, match="windows must be a non-empty list"):
        metrics.shortest_window(factory, t, [], 10.0)


# --------------------------------------------------------------------------- over trials
def test_trial_statistics_against_numpy_and_expected_bias():
    rng = np.random.default_rng(3)
    truth = 11.5
    est = truth + 0.2 + 0.1 * rng.standard_normal(2000)
    est[:5] = np.nan
    s = metrics.trial_statistics(est, truth)
    finite = est[5:]
    assert s["n"] == 1995 and s["n_missing"] == 5
    assert s["mean"] == pytest.approx(finite.mean(), rel=1e-14)
    assert s["std"] == pytest.approx(finite.std(ddof=1), rel=1e-14)
    assert s["rmse"] == pytest.approx(np.sqrt(np.mean((finite - truth) ** 2)), rel=1e-14)
    # bias 0.2 +- 3 standard errors (0.1 / sqrt(1995))
    assert abs(s["bias"] - 0.2) < 3 * 0.1 / math.sqrt(1995)
    assert s["relative_spread"] == pytest.approx(s["std"] / truth)
    empty = metrics.trial_statistics([np.nan], truth)
    assert empty["n"] == 0 and math.isnan(empty["mean"])


def test_censored_median_counts_nan_as_never():
    assert metrics.censored_median([0.3, np.nan, 0.1, 0.2, np.nan]) == pytest.approx(0.3)
    assert math.isnan(metrics.censored_median([0.3, np.nan, np.nan]))


# --------------------------------------------------------------------------- errors
def test_metric_errors_name_the_argument():
    t = _time(0.1)
    with pytest.raises(ShapeError, match="estimate has 3 samples but t has"):
        metrics.first_hit_time(t, [1, 2, 3], 1.0)
    with pytest.raises(InputError, match="truth must be finite and non-zero"):
        metrics.relative_error([1.0, 2.0], 0.0)
    with pytest.raises(ShapeError, match="truth must be a scalar or have one value per sample"):
        metrics.relative_error([1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match=r"fraction must lie in \(0, 1\]"):
        metrics.settle_time(t, np.ones(t.size), 1.0, fraction=1.5)
    with pytest.raises(InputError, match="tolerance must be finite and > 0"):
        metrics.first_hit_time(t, np.ones(t.size), 1.0, tolerance=-0.1)
    with pytest.raises(ShapeError, match="valid must have one flag per sample"):
        metrics.within_tolerance(np.ones(3), 1.0, valid=[True])
    with pytest.raises(SamplingError, match="not uniformly sampled"):
        metrics.settle_time([0.0, 0.001, 0.003, 0.004], np.ones(4), 1.0)
