"""Test (c) of `physid.analysis.validation`: residual analysis (MATLAB ``resid``), the whiteness
of a residual and its independence from the input against the 99 % band."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import InputError

__all__ = ["residual_analysis", "MAX_LAG", "BAND_Z"]

#: Lags of the residual tests (MATLAB ``resid``'s default).
MAX_LAG = 25
#: Two-sided 99 % quantile of the standard normal: the band is ``± BAND_Z / √N``.
BAND_Z = 2.5758293035489004


def residual_analysis(residual, inputs=None, *, max_lag: int = MAX_LAG) -> dict[str, Any]:
    """Whiteness and independence tests of a residual (MATLAB ``resid``).

    Parameters
    ----------
    residual : array_like, shape (n_samples,) or (n_samples, n_outputs)
        Prediction errors; each column is tested.
    inputs : array_like, shape (n_samples,) or (n_samples, n_inputs), optional
        The input(s) for the cross-correlation test.
    max_lag : int
        Lags ``1..max_lag`` (autocorrelation) and ``−max_lag..max_lag`` (cross-correlation).

    Returns
    -------
    dict
        ``lags`` (the cross-correlation lags), ``band`` (``BAND_Z / √N``, the 99 % band),
        ``autocorrelation`` (per residual column: lags 0..max_lag, 1 at lag 0),
        ``cross_correlation`` (per residual × input pair: lags −max_lag..max_lag),
        ``autocorrelation_outside`` / ``cross_correlation_outside`` (lags outside the band),
        ``white``, ``independent`` (bool) and a one-line ``verdict``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> r = residual_analysis(rng.normal(size=5000), rng.normal(size=5000))
    >>> r["white"], r["independent"]
    (True, True)
    """
    e = np.asarray(residual, dtype=float)
    e = e[:, None] if e.ndim == 1 else e
    n = e.shape[0]
    if n <= 2 * max_lag + 1:
        raise InputError(
            f"residual_analysis needs more than {2 * max_lag + 1} samples for max_lag="
            f"{max_lag}; got {n}. Use a longer held-out record."
        )
    band = BAND_Z / np.sqrt(n)
    lags = np.arange(-max_lag, max_lag + 1)
    bad = int(np.count_nonzero(~np.isfinite(e).all(axis=1)))
    if bad:  # NaN compares False with the band: it would pass every test as "white"
        return _untestable(
            lags,
            band,
            f"residual is not finite at {bad} of {n} samples (the prediction or the data hold "
            "NaN or inf): no residual test is possible and nothing says the model explains "
            "the data",
        )
    e = e - e.mean(axis=0)
    if not np.any(e):
        return _untestable(
            lags,
            band,
            "residual is constant (zero after removing its mean): no whiteness test is possible; "
            "the prediction reproduces the data to rounding, so check that the held-out output "
            "is measured, not computed from the model",
        )

    def xcorr(a, b):  # r_ab(k) = Σ a(t+k) b(t) / √(Σa² Σb²), k = −L..L (biased, as resid)
        # only the 2L+1 lags used, one dot product each: O(n·L) time, O(n) memory (the full
        # correlation, np.correlate(mode="full"), is O(n²): 8 s at 8e4 samples)
        seg = np.array(
            [float(a[k:] @ b[: n - k]) if k >= 0 else float(a[: n + k] @ b[-k:]) for k in lags]
        )
        den = np.sqrt(float(a @ a) * float(b @ b))
        return seg / den if den > 0 else np.full(seg.size, np.nan)

    auto = [xcorr(e[:, j], e[:, j])[max_lag:] for j in range(e.shape[1])]
    auto_out = [int(np.count_nonzero(np.abs(a[1:]) > band)) for a in auto]
    cross, cross_out = [], []
    if inputs is not None:
        u = np.asarray(inputs, dtype=float)
        u = u[:, None] if u.ndim == 1 else u
        u = u - u.mean(axis=0)
        for j in range(e.shape[1]):
            for k in range(u.shape[1]):
                c = xcorr(e[:, j], u[:, k])
                cross.append(c)
                cross_out.append(int(np.count_nonzero(np.abs(c) > band)))
    # With 25 (51) independent lags, a white residual leaves about 0.25 (0.5) of them outside the
    # 99 % band, so one lag outside is no evidence (26 % (40 %) chance). A test fails when 2 or
    # more lags are outside (chance 2.6 % (9 %)) or one is outside the Bonferroni band
    # z = Φ⁻¹(1 − 0.005 / n_lags) (family-wise 1 %).
    from scipy.stats import norm

    def fails(values, n_lags):
        strict = norm.ppf(1.0 - 0.005 / n_lags) / np.sqrt(n)
        v = np.abs(np.asarray(values))
        return int(np.count_nonzero(v > band)) >= 2 or bool(np.any(v > strict))

    white = not any(fails(a[1:], max_lag) for a in auto)
    independent = not any(fails(c, 2 * max_lag + 1) for c in cross)
    if white and independent:
        verdict = (
            "residual is white and uncorrelated with the input (99 % band): the model explains "
            "the data"
        )
    elif not independent:
        verdict = (
            "residual is correlated with the input (outside the 99 % band at "
            f"{max(cross_out)} lags): the model misses part of the input-output dynamics"
        )
    else:
        verdict = (
            f"residual is not white (autocorrelation outside the 99 % band at {max(auto_out)} "
            "lags): unmodelled dynamics or coloured noise; the input-output part may be fine"
        )
    return {
        "lags": lags,
        "band": float(band),
        "autocorrelation": auto,
        "cross_correlation": cross,
        "autocorrelation_outside": auto_out,
        "cross_correlation_outside": cross_out,
        "white": bool(white),
        "independent": bool(independent),
        "verdict": verdict,
    }


def _untestable(lags, band: float, verdict: str) -> dict:
    """The result of `residual_analysis` when its tests cannot run: neither white nor
    independent, and the ``verdict`` says why."""
    return {
        "lags": lags,
        "band": float(band),
        "autocorrelation": [],
        "cross_correlation": [],
        "autocorrelation_outside": [],
        "cross_correlation_outside": [],
        "white": False,
        "independent": False,
        "verdict": verdict,
    }


def _enough_for_residual(n: int, max_lag: int, what: str, notes: list[str]) -> bool:
    """Whether (c) can run on ``n`` rows; if not, a note says why it was skipped (not an error:
    (a) and (b) stand on their own)."""
    if n > 2 * max_lag + 1:
        return True
    notes.append(
        f"(c) skipped: the residual tests at ±{max_lag} lags need more than {2 * max_lag + 1} "
        f"{what}; the held-out record gives {n}. Use a longer held-out record for (c)."
    )
    return False
