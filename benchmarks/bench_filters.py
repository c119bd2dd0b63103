"""Differential filters against Savitzky–Golay: throughput and derivative accuracy.

Rows
----
1. Throughput (samples/s, channels counted) of design + application of the first- and
   second-derivative filters with M = 100 (201 taps) on 1e6 × 4 samples (quick: 1e5 × 4) against
   ``scipy.signal.savgol_filter`` with the same 201-point window (polyorder 2 for d/dt, 3 for
   d²/dt²: the same polynomial exactness as ours), measured in the same run, best of 3.
2. RMS error of d/dt and d²/dt² of a noisy multisine (1, 2.5, 4 and 7 Hz at Δ = 1 ms, white
   noise at SNR 40 dB, 8 seeded realisations) on the valid range, against Savitzky–Golay with the
   same window. Our cut-off follows the rule of docs/filters.md, Ω_g = Ω_max + 3π/M
   (= 0.044 + 0.094 ≈ 0.14 rad/sample): the highest signal frequency sits in the flat part of the
   pass band. Two baselines: savgol with the polyorder of the same exactness (2 for d/dt, 3 for
   d²/dt²), and — for honesty — savgol with the best polyorder found by scanning 2..7 against
   the true derivative (an oracle choice no user has).
3. pynumdiff, if importable (it is not a physid dependency; the row says so when missing).
4. ``physid.analysis.validation.residual_analysis`` (the ``validate`` command's test (c): one
   autocorrelation and one cross-correlation at ±25 lags) on white noise of 2e4, 8e4 and 6e5
   samples (quick: 2e4), against the full ``np.correlate(mode="full")`` over every lag
   (O(n²); timed only up to 8e4 samples, ~8 s there on a loaded machine), best of 3. The
   correlations agree to 1e-12 (the tests check it).
"""

from __future__ import annotations

import numpy as np
from _timing import best_time
from scipy.signal import savgol_filter

from physid.filters import design_filter

M = 100
DT = 1e-3
FREQS_HZ = np.array([1.0, 2.5, 4.0, 7.0])
AMPLITUDES = np.array([1.0, 0.6, 0.4, 0.25])
PHASES = np.array([0.0, 1.0, 2.0, 3.0])
SNR_DB = 40.0


def _throughput_rows(quick: bool) -> list[dict]:
    n = 100_000 if quick else 1_000_000
    x = np.random.default_rng(0).standard_normal((n, 4))
    repeats = 2 if quick else 3
    rows = []
    for kind, order, polyorder in (("first", 1, 2), ("second", 2, 3)):

        def ours(kind=kind):
            return design_filter(kind, M, 0.2, DT).apply(x)

        def savgol(order=order, polyorder=polyorder):
            return savgol_filter(x, 2 * M + 1, polyorder, deriv=order, delta=DT, axis=0)

        ours()  # warm-up (FFT plans, imports)
        t_ours = best_time(ours, repeats)
        t_sg = best_time(savgol, repeats)
        rate, rate_sg = x.size / t_ours, x.size / t_sg
        rows.append(
            {
                "case": f"throughput d^{order}/dt^{order}, M={M} (201 taps), {n:.0e}x4",
                "value": rate,
                "unit": "samples/s",
                "baseline": f"savgol_filter(201, polyorder={polyorder}, deriv={order})",
                "baseline_value": rate_sg,
                "ratio": rate / rate_sg,
                "goal": ">= savgol throughput",
                "met": bool(rate >= rate_sg),
            }
        )
    return rows


def _multisine(n: int, n_trials: int):
    t = DT * np.arange(n)
    omega = 2 * np.pi * FREQS_HZ
    arg = np.outer(t, omega) + PHASES
    value = np.sin(arg) @ AMPLITUDES
    first = np.cos(arg) @ (AMPLITUDES * omega)
    second = -np.sin(arg) @ (AMPLITUDES * omega**2)
    sigma = np.sqrt(np.mean(value**2)) * 10 ** (-SNR_DB / 20)
    noisy = value[:, None] + sigma * np.random.default_rng(40).standard_normal((n, n_trials))
    return t, noisy, first, second


def _rms(estimate: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean((estimate - truth[:, None]) ** 2)))


def _accuracy_rows(quick: bool) -> list[dict]:
    n = 5_001 if quick else 20_001
    t, noisy, first, second = _multisine(n, 8)
    omega_max = 2 * np.pi * FREQS_HZ.max() * DT  # [rad/sample]
    cutoff = round(omega_max + 3 * np.pi / M, 2)  # the rule of docs/filters.md -> 0.14
    valid = slice(M, n - M)
    rows = []
    for order, truth, exact_poly in ((1, first, 2), (2, second, 3)):
        ours = _rms(design_filter(order, M, cutoff, DT).apply(noisy), truth[valid])

        def savgol_error(p, order=order, truth=truth):
            est = savgol_filter(noisy, 2 * M + 1, p, deriv=order, delta=DT, axis=0)
            return _rms(est[valid], truth[valid])

        same = savgol_error(exact_poly)
        scan = {p: savgol_error(p) for p in range(max(order, 2), 8)}
        best_p = min(scan, key=scan.get)
        unit = "m/s" if order == 1 else "m/s^2"
        label = f"RMS error d^{order}x/dt^{order}, multisine SNR {SNR_DB:g} dB, Ω_g={cutoff:g}"
        rows.append(
            {
                "case": label,
                "value": ours,
                "unit": unit,
                "baseline": f"savgol 201 pts, polyorder {exact_poly} (same exactness)",
                "baseline_value": same,
                "ratio": same / ours,
                "goal": "<= savgol error at equal window",
                "met": bool(ours <= same),
            }
        )
        rows.append(
            {
                "case": label + " (vs oracle polyorder)",
                "value": ours,
                "unit": unit,
                "baseline": f"savgol 201 pts, best polyorder {best_p} of 2..7 (oracle)",
                "baseline_value": scan[best_p],
                "ratio": scan[best_p] / ours,
                "goal": "information (oracle-tuned peer)",
                "met": bool(ours <= scan[best_p]),
            }
        )
    rows.extend(_pynumdiff_rows(t, noisy, first, valid, cutoff))
    return rows


def _pynumdiff_rows(t, noisy, first, valid, cutoff) -> list[dict]:
    try:
        import pynumdiff  # noqa: F401
    except ImportError:
        return [
            {
                "case": "RMS error d/dt vs pynumdiff",
                "value": None,
                "unit": "m/s",
                "baseline": "pynumdiff (not installed: row skipped)",
                "goal": "<= pynumdiff error",
                "met": None,
            }
        ]
    ours = _rms(design_filter("first", M, cutoff, DT).apply(noisy), first[valid])
    try:
        from pynumdiff.smooth_finite_difference import butterdiff

        estimates = []
        for j in range(noisy.shape[1]):
            # Butterworth (order 3, cut-off = ours as a fraction of Nyquist) + finite difference
            _, dxdt = butterdiff(noisy[:, j], DT, [3, cutoff / np.pi], options={"iterate": False})
            estimates.append(dxdt)
    except Exception as exc:  # pynumdiff's signature changed across versions; say so, don't crash
        return [
            {
                "case": "RMS error d/dt vs pynumdiff",
                "value": ours,
                "unit": "m/s",
                "baseline": f"pynumdiff.butterdiff failed ({type(exc).__name__}: {exc})",
                "goal": "<= pynumdiff error",
                "met": None,
            }
        ]
    peer = _rms(np.column_stack(estimates)[valid], first[valid])
    return [
        {
            "case": "RMS error d/dt vs pynumdiff butterdiff",
            "value": ours,
            "unit": "m/s",
            "baseline": "pynumdiff.butterdiff (order 3, same cut-off)",
            "baseline_value": peer,
            "ratio": peer / ours,
            "goal": "<= pynumdiff error",
            "met": bool(ours <= peer),
        }
    ]


def _full_correlation_lags(a, b, max_lag):
    """The O(n²) baseline: every lag by np.correlate, then the ±max_lag slice."""
    n = a.size
    return np.correlate(a, b, mode="full")[n - 1 - max_lag : n + max_lag]


def _residual_rows(quick: bool) -> list[dict]:
    from physid.analysis.validation import residual_analysis

    rng = np.random.default_rng(3)
    rows = []
    for n in (20_000,) if quick else (20_000, 80_000, 600_000):
        e, u = rng.standard_normal(n), rng.standard_normal(n)
        t_new = best_time(lambda e=e, u=u: residual_analysis(e, u), 1 if quick else 3)
        t_old = None
        if n <= 80_000:  # the O(n²) baseline: one auto- and one cross-correlation
            t_old = best_time(
                lambda e=e, u=u: (
                    _full_correlation_lags(e, e, 25),
                    _full_correlation_lags(e, u, 25),
                ),
                1,
            )
        rows.append(
            {
                "case": f"residual_analysis (test (c)), {n:.0e} samples, ±25 lags",
                "value": t_new,
                "unit": "s",
                "baseline": "np.correlate(mode='full') (every lag, O(n²))",
                "baseline_value": t_old,
                "ratio": None if t_old is None else t_old / t_new,
                "goal": "O(n*L): < 1 s at 6e5 samples",
                "met": bool(t_new < 1.0) if n == 600_000 else None,
            }
        )
    return rows


def run(quick: bool = False) -> list[dict]:
    """Rows for benchmarks/run.py (see the module docstring)."""
    return _throughput_rows(quick) + _accuracy_rows(quick) + _residual_rows(quick)


if __name__ == "__main__":
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
