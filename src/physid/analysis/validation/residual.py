"""Test (c) of `physid.analysis.validation`: residual analysis (MATLAB ``resid``), the whiteness
of a residual and its independence from the input against the 99 % band."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import InputError

__all__ = ["residual_analysis", "explain_residual", "MAX_LAG", "BAND_Z", "RESOLUTION"]

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

    auto = [_xcorr(e[:, j], e[:, j], lags)[max_lag:] for j in range(e.shape[1])]
    auto_out = [int(np.count_nonzero(np.abs(a[1:]) > band)) for a in auto]
    cross, cross_out = [], []
    if inputs is not None:
        u = np.asarray(inputs, dtype=float)
        u = u[:, None] if u.ndim == 1 else u
        u = u - u.mean(axis=0)
        for j in range(e.shape[1]):
            for k in range(u.shape[1]):
                c = _xcorr(e[:, j], u[:, k], lags)
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
    verdict = _verdict_text(white, independent, auto_out, cross_out)
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


def _xcorr(a, b, lags) -> np.ndarray:
    """r_ab(k) = Σ a(t+k) b(t) / √(Σa² Σb²) at ``lags`` (biased, as MATLAB's resid).

    Only the 2L+1 lags used, one dot product each: O(n·L) time, O(n) memory (the full
    correlation, np.correlate(mode="full"), is O(n²): 8 s at 8e4 samples).
    """
    n = a.shape[0]
    seg = np.array(
        [float(a[k:] @ b[: n - k]) if k >= 0 else float(a[: n + k] @ b[-k:]) for k in lags]
    )
    den = np.sqrt(float(a @ a) * float(b @ b))
    return seg / den if den > 0 else np.full(seg.size, np.nan)


def _verdict_text(white: bool, independent: bool, auto_out, cross_out) -> str:
    """The residual test's verdict in words."""
    if white and independent:
        return (
            "residual is white and uncorrelated with the input (99 % band): the model explains "
            "the data"
        )
    if not independent:
        return (
            "residual is correlated with the input (outside the 99 % band at "
            f"{max(cross_out)} lags): the model misses part of the input-output dynamics"
        )
    return (
        f"residual is not white (autocorrelation outside the 99 % band at {max(auto_out)} "
        "lags): unmodelled dynamics or coloured noise; the input-output part may be fine"
    )


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


#: A residual smaller than this fraction of the output's spread (fit above 99.99 %) is at the
#: resolution of a simulation driven by a sampled input (the noise-free MSD of the paper at
#: 1 kHz, simulated with its true parameters, leaves 1.7e-5); its correlations are those of the
#: numerical error, not evidence about the model.
RESOLUTION = 1e-4


#: Input noise is named only if the σ it needs is at most this factor times the white-noise
#: level the measured input's second difference allows (std(Δ²u_m) / √6).
NOISE_BOUND_FACTOR = 1.5


def _fit_shape(observed, shape):
    """Least-squares scale ``s`` of ``shape`` to ``observed`` and the remainder."""
    den = float(shape @ shape)
    s = float(observed @ shape) / den if den > 0 else 0.0
    return s, observed - s * shape


def explain_residual(result: dict[str, Any], residual, output, impulse, *, inputs=None) -> None:
    """Say which explanation the data support when test (c) fails, with the numbers.

    A failed test is not always a wrong model. Two other explanations are checked first:

    * **resolution**: a simulation driven by a sampled input is exact only to about `RESOLUTION`
      of the output's spread (a noise-free record with the true parameters leaves that much), and
      a residual of that size can correlate with anything up to ``RESOLUTION ‖y − ȳ‖ / ‖e‖``.
      Correlations no larger than that (beyond the 99 % band) are not counted against the model;
    * **noise on the measured input** (errors in variables): the model is driven by
      ``u_m = u + n`` while the output answered ``u``, so ``e = y − ŷ = −G n`` (+ output noise).
      For white ``n`` of variance σ² the autocorrelation of ``e`` has the shape of the model's
      impulse response's (``Σ g(j) g(j+k)``), diluted by white output noise (one scale ``w``,
      the input noise's share, fitted), σ follows from the residual's power
      (``w ‖e‖² ≈ w N σ² Σ g²``), and the cross-correlation of ``e`` with ``u_m`` is then
      predicted with no free parameter: ``−σ² N g(k) / (‖e‖ ‖u_m‖)`` at lags k ≥ 0, 0 at k < 0.
      When what remains of both passes the tests (the cross-correlation's band widened for a
      coloured residual, Bartlett's formula) and the σ needed is no more than
      `NOISE_BOUND_FACTOR` times what the measured input's second difference allows
      (``std(Δ²u_m) / √6``, the white-noise level in it), input noise explains the residual.

    Otherwise the model is named (a model error ``(G − Ĝ) u`` correlates with a coloured input at
    negative lags too, and not as the input noise predicts), with how much input noise explains.
    (Long by its docstring: the three explanations are written out where they are decided.)

    Parameters
    ----------
    result : dict
        `residual_analysis` of one residual against one input; updated in place: ``verdict``,
        ``explanation`` (``"model"``, ``"input noise"``, ``"resolution"``, ``"none"``) and
        ``evidence`` (the numbers).
    residual, output : array_like, shape (n_samples,)
        ``e = y − ŷ`` and the measured output ``y``.
    impulse : array_like, shape (n_samples,)
        The identified model's response to one unit input sample, ``g`` [output unit].
    inputs : array_like, shape (n_samples,), optional
        The measured input (for the cross-correlation's prediction and the input's SNR).
    """
    e = np.asarray(residual, dtype=float).ravel()
    e = e - e.mean()
    y = np.asarray(output, dtype=float).ravel()
    spread, size = float(np.linalg.norm(y - y.mean())), float(np.linalg.norm(e))
    rel = size / spread if spread > 0 else float("nan")
    floor = RESOLUTION / rel if rel > 0 else 0.0
    evidence: dict[str, Any] = {"relative_residual": rel, "resolution_correlation": floor}
    result["evidence"] = evidence
    if result["white"] and result["independent"]:
        result["explanation"] = "none"
        return
    if rel < RESOLUTION:
        result["explanation"] = "resolution"
        result["verdict"] = (
            f"consistent: the residual is {rel:.2g} of the output's spread (below {RESOLUTION:g},"
            " the resolution of a simulation from sampled data), so its correlations are those "
            "of the numerical error, not evidence against the model"
        )
        return
    n, lag_max = e.size, (len(result["lags"]) - 1) // 2
    passes = _passes(result["band"], n, floor)
    auto = np.asarray(result["autocorrelation"][0], dtype=float)[1:]
    cross, passes_cross = None, passes
    if inputs is not None:
        cross = np.asarray(result["cross_correlation"][0], dtype=float)
        # a coloured residual against a coloured input: the chance cross-correlation's variance
        # is Σ ρ_e(j) ρ_u(j) / N (Bartlett), not 1/N; the band widens by its square root
        inflation = _bartlett_inflation(e, np.asarray(inputs, dtype=float).ravel())
        evidence["cross_band_inflation"] = inflation
        passes_cross = _passes(result["band"] * inflation, n, floor, scale=inflation)
    ok, sigma = _input_noise_fits(result, e, impulse, inputs, passes, passes_cross)
    if ok:
        result["explanation"] = "input noise"
        result["verdict"] = _input_noise_verdict(result, evidence)
    elif passes(auto, lag_max) and (cross is None or passes(cross, 2 * lag_max + 1)):
        result["explanation"] = "resolution"
        result["verdict"] = (
            f"consistent: the residual is {rel:.2g} of the output's spread and its correlations "
            f"outside the 99 % band are no larger than {floor:.2g}, what a residual at the "
            f"resolution of a simulation from sampled data ({RESOLUTION:g}) can cause"
        )
    else:
        result["explanation"] = "model"
        result["verdict"] += (
            "; noise on the measured input does not explain it (it would need σ ≈ "
            f"{sigma:.3g}, the input's second difference allows "
            f"{evidence.get('input_noise_bound', float('nan')):.3g}; its prediction accounts "
            f"for {_percent(evidence.get('cross_correlation_explained'))} of the "
            "cross-correlation)"
        )


def _input_noise_fits(result, e, impulse, inputs, passes, passes_cross):
    """Whether input noise explains the residual's correlations (see `explain_residual`); its σ.

    Adds the numbers to ``result["evidence"]``.
    """
    evidence = result["evidence"]
    n, lag_max = e.size, (len(result["lags"]) - 1) // 2
    size = float(np.linalg.norm(e))
    auto = np.asarray(result["autocorrelation"][0], dtype=float)[1:]
    g = np.asarray(impulse, dtype=float).ravel()
    gg = np.array([float(g[k:] @ g[: n - k]) for k in range(lag_max + 1)])
    w, auto_left = _fit_shape(auto, gg[1:] / gg[0] if gg[0] > 0 else np.zeros(lag_max))
    ok = 0.0 < w <= 1.05 and passes(auto_left, lag_max)
    evidence["input_noise_share"] = float(np.clip(w, 0.0, 1.0))
    evidence["autocorrelation_explained"] = _explained(auto, auto_left)
    sigma = float(np.sqrt(np.clip(w, 0.0, 1.0) * size**2 / (n * gg[0]))) if gg[0] > 0 else 0.0
    evidence["input_noise_std"] = sigma
    if inputs is not None:
        cross = np.asarray(result["cross_correlation"][0], dtype=float)
        u = np.asarray(inputs, dtype=float).ravel()
        u = u - u.mean()
        lags = np.asarray(result["lags"])
        g_at = np.where(lags >= 0, g[np.clip(lags, 0, n - 1)], 0.0)
        predicted = -(sigma**2) * n * g_at / (size * float(np.linalg.norm(u)))
        cross_left = cross - predicted
        ok = ok and passes_cross(cross_left, 2 * lag_max + 1)
        # the input itself bounds its white noise: var(Δ²n) = 6σ², and a smooth signal adds
        # little to the second difference; a σ far above that bound is not in the input
        bound = float(np.std(np.diff(u, 2))) / np.sqrt(6.0)
        evidence["input_noise_bound"] = bound
        ok = ok and sigma <= NOISE_BOUND_FACTOR * bound
        evidence["cross_correlation_explained"] = _explained(cross, cross_left)
        if sigma > 0:
            evidence["input_snr_db"] = float(20 * np.log10(float(np.std(u)) / sigma))
    return ok, sigma


def _bartlett_inflation(e, u) -> float:
    """√(Σ_j w_j ρ_e(j) ρ_u(j)) over |j| < N/10 (triangular taper w), at least 1.

    The standard deviation of the sample cross-correlation of two independent stationary
    series, in units of 1/√N (Bartlett 1946); 1 when either is white.
    """
    n = e.size
    m = max(n // 10, 1)
    size = 1 << int(np.ceil(np.log2(2 * n)))

    def rho(x):
        x = x - x.mean()
        f = np.fft.rfft(x, size)
        r = np.fft.irfft(f * np.conj(f), size)[:m]
        return r / r[0] if r[0] > 0 else np.zeros(m)

    taper = 1.0 - np.arange(m) / m
    both = rho(e) * rho(u) * taper
    total = float(both[0] + 2.0 * both[1:].sum())
    return float(np.sqrt(max(total, 1.0)))


def _passes(band: float, n: int, floor: float, scale: float = 1.0):
    """The test of `residual_analysis` with both bands widened by ``floor`` (and ``scale``)."""
    from scipy.stats import norm

    def passes(values, n_lags) -> bool:
        strict = scale * norm.ppf(1.0 - 0.005 / n_lags) / np.sqrt(n) + floor
        v = np.abs(np.asarray(values))
        return int(np.count_nonzero(v > band + floor)) < 2 and not bool(np.any(v > strict))

    return passes


def _explained(observed, left) -> float:
    total = float(observed @ observed)
    return float(1.0 - float(left @ left) / total) if total > 0 else float("nan")


def _percent(value) -> str:
    return "n/a" if value is None or not np.isfinite(value) else f"{100 * max(value, 0.0):.0f} %"


def _input_noise_verdict(result, evidence) -> str:
    failed = []
    if not result["independent"]:
        failed.append(
            f"correlated with the input at {max(result['cross_correlation_outside'])} lags"
        )
    if not result["white"]:
        failed.append(f"not white at {max(result['autocorrelation_outside'])} lags")
    noise = ""
    if "input_noise_std" in evidence:
        noise = (
            f", σ ≈ {evidence['input_noise_std']:.3g} needed, the input's second difference "
            f"allows {evidence.get('input_noise_bound', float('nan')):.3g}"
        )
        if "input_snr_db" in evidence:
            noise += f" (input SNR ≈ {evidence['input_snr_db']:.0f} dB)"
    explained = f"{_percent(evidence['autocorrelation_explained'])} of the autocorrelation"
    if not result["independent"]:
        cross = _percent(evidence.get("cross_correlation_explained"))
        explained = f"{cross} of the cross-correlation and " + explained
    return (
        f"consistent with the model once noise on the measured input is counted: the residual is "
        f"{' and '.join(failed)}, the pattern the model's own impulse response gives to input "
        f"noise (it explains {explained}{noise}); what remains passes both tests. Reduce the "
        "input's noise or use an errors-in-variables estimate; the model need not change"
    )
