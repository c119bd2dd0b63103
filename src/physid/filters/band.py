"""Does a filter's pass band fit a signal? The band check and the automatic filter choice.

`filter_band_check` measures how much of a motion lies where the low-pass filter is not flat (the
check the input-error estimator runs before a fit). `choose_filter` picks the half-width M and the
cut-off Ω_g from the data: the signal band and the noise floor are read from the spectrum of q,
and the lowest-noise filter whose flat band still covers the signal band is chosen.

Why both ends matter (Cedro & Janecki, eq. 6; ``docs/input-error.md``): the filtered equations
of motion balance only where all three filters act as the ideal ``1, s, s²``, so a cut-off below
the motion biases the estimates ("too low: bias"); noise on q enters the regressor through
q̈^f, whose white-noise gain grows like ``Ω_g^2.5/Δ²``, and biases the inertia terms towards zero
("too high: noise"). The lowest cut-off that clears the motion is the best one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .differential import design_filter

__all__ = [
    "PASSBAND_TOL",
    "ENERGY_FRACTION_WARN",
    "FilterBandCheck",
    "filter_band_check",
    "passband_edge",
    "noise_floor",
    "quantisation_step",
    "white_floor",
    "FilterChoice",
    "choose_filter",
]

#: |H(Ω) - 1| tolerance defining the low-pass filter's accurate pass band (`filter_band_check`).
PASSBAND_TOL = 1e-3
#: Fraction of the energy of Δq outside the accurate pass band above which the estimator warns.
ENERGY_FRACTION_WARN = 1e-4
#: Energy fraction `choose_filter` leaves above the flat band when no noise floor is visible.
CLEAN_FRACTION = 1e-6


def passband_edge(half_width: int, cutoff: float, dt: float = 1.0) -> float:
    """Highest Ω [rad/sample] below which the low-pass gain stays within ``PASSBAND_TOL`` of 1.

    Parameters
    ----------
    half_width : int
        M (the filter has 2M + 1 taps).
    cutoff : float [rad/sample]
        Ω_g.
    dt : float [s]
        Sample period (the low-pass gain does not depend on it).

    Returns
    -------
    float [rad/sample]
        With the Harris window about ``Ω_g - 8π/(2M+1)`` (0.106 for M = 100, Ω_g = 0.2).

    Examples
    --------
    >>> round(passband_edge(100, 0.2), 3)
    0.106
    """
    lowpass = design_filter("lowpass", half_width, cutoff, dt)
    omega = np.linspace(0.0, cutoff, 801)
    n = np.arange(-lowpass.half_width, lowpass.half_width + 1)
    gain = np.cos(np.outer(omega, n)) @ lowpass.taps  # even taps: H(Ω) = Σ c[n] cos(Ωn), real
    gain_error = np.abs(gain - 1.0)
    bad = np.nonzero(gain_error > PASSBAND_TOL)[0]
    return float(omega[bad[0]]) if bad.size else float(cutoff)


@dataclass(frozen=True)
class FilterBandCheck:
    """Result of `filter_band_check`.

    Attributes
    ----------
    passband_edge : float [rad/sample]
        Highest Ω below which the low-pass gain stays within ``PASSBAND_TOL`` of 1.
    fractions : ndarray, shape (n_channels,)
        Per channel, the fraction of the energy of the first difference of q (≈ q̇Δ) above
        ``passband_edge``.
    threshold : float
        Fraction above which the check fails.
    """

    passband_edge: float
    fractions: np.ndarray
    threshold: float

    @property
    def ok(self) -> bool:
        """True when every channel keeps its energy inside the accurate pass band."""
        return bool(np.all(self.fractions <= self.threshold))


def _rate_spectrum(q) -> tuple[np.ndarray, np.ndarray]:
    """Periodogram of the first difference of each column of q, and its frequencies [rad/sample]."""
    dq = np.diff(np.asarray(q, dtype=float), axis=0)
    if dq.ndim == 1:
        dq = dq[:, None]
    power = np.abs(np.fft.rfft(dq - dq.mean(axis=0), axis=0)) ** 2
    freq = 2.0 * np.pi * np.fft.rfftfreq(dq.shape[0])
    return power, freq


def filter_band_check(
    q, half_width: int, cutoff: float, dt: float, *, threshold=ENERGY_FRACTION_WARN
):
    """Measure how much of the motion lies where the low-pass filter is not flat.

    Rule (documented in ``docs/input-error.md``): the identification is unbiased only where all
    three filters act as the ideal ``1, s, s²``, i.e. in the flat part of the pass band. The flat
    part ends at ``Ω_p``, the lowest frequency where ``|H_lowpass(Ω) - 1| > 1e-3``; with the Harris
    window it lies about ``8π/(2M+1)`` below Ω_g (0.07 rad/sample for the paper's M = 100,
    Ω_g = 0.2). We take the spectrum of the first difference of each q (which weights the
    frequencies like the velocity does, so the steps' DC content does not swamp it) and report
    the fraction of its energy above ``Ω_p``.

    Parameters
    ----------
    q : array_like, shape (n_samples, n_channels)
        Joint angles [rad].
    half_width : int
        M.
    cutoff : float [rad/sample]
        Ω_g.
    dt : float [s]
        Sample period.
    threshold : float
        Fraction above which `FilterBandCheck.ok` is False.

    Returns
    -------
    FilterBandCheck
    """
    edge = passband_edge(half_width, cutoff, dt)
    power, freq = _rate_spectrum(q)
    total = power.sum(axis=0)
    above = power[freq > edge].sum(axis=0)
    fractions = np.divide(above, total, out=np.zeros_like(total), where=total > 0)
    return FilterBandCheck(edge, fractions, float(threshold))


@dataclass(frozen=True)
class FilterChoice:
    """The filter `choose_filter` picked, and why.

    Attributes
    ----------
    half_width : int
        M.
    cutoff : float [rad/sample]
        Ω_g.
    passband_edge : float [rad/sample]
        Where the chosen low-pass stops being flat (see `passband_edge`); at or above
        ``signal_band``.
    signal_band : float [rad/sample]
        Highest frequency of the motion that must pass: the frequency below which all but
        ``ENERGY_FRACTION_WARN`` of the energy of Δq lies once the noise floor is removed, capped
        where the motion sinks into the noise (worst joint).
    noise_band : float [rad/sample]
        Above this frequency the spectrum of Δq is noise (the signal is below the noise floor on
        every joint); ``π`` when no noise floor is visible.
    noise_std : ndarray, shape (n_channels,)
        Estimated standard deviation of white noise on each q (same unit as q).
    reason : str
        One sentence saying what was chosen and why.
    """

    half_width: int
    cutoff: float
    passband_edge: float
    signal_band: float
    noise_band: float
    noise_std: np.ndarray
    reason: str

    @property
    def noisy(self) -> bool:
        """True when the motion sinks into the noise floor below π/2 rad/sample.

        Then the noise reaches frequencies a cut-off could pass, and a higher Ω_g adds noise.
        """
        return bool(self.noise_band < 0.5 * np.pi)


def _smooth(power: np.ndarray, width: int) -> np.ndarray:
    """Moving average along axis 0 (a periodogram's bins scatter by 100 %)."""
    if width <= 1:
        return power
    kernel = np.ones(width) / width
    padded = np.pad(power, ((width // 2, width - 1 - width // 2), (0, 0)), mode="edge")
    return np.apply_along_axis(lambda c: np.convolve(c, kernel, mode="valid"), 0, padded)


def quantisation_step(q) -> np.ndarray:
    """Step Δ of the grid each column of q takes its values on (an encoder's resolution).

    A column is quantised when every sample is ``q[0] + k·Δ`` for integers k, Δ the smallest gap
    between its distinct values (within 1 % of Δ, and Δ above 1e-9 of the column's range, so the
    rounding of floating-point numbers does not count as a grid).

    Parameters
    ----------
    q : array_like, shape (n_samples, n_channels)

    Returns
    -------
    ndarray, shape (n_channels,)
        Δ per channel (the unit of q); 0 where the column lies on no grid (or is constant).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 10, 10001)
    >>> q = np.column_stack([np.round(np.sin(t) / 1e-6) * 1e-6, np.sin(t)])
    >>> [float(f"{d:.3g}") for d in quantisation_step(q)]
    [1e-06, 0.0]
    """
    arr = np.asarray(q, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    out = np.zeros(arr.shape[1])
    for j in range(arr.shape[1]):
        col = arr[:, j]
        levels = np.unique(col[np.isfinite(col)])
        if levels.size < 3:
            continue
        gaps = np.diff(levels)
        gaps = gaps[gaps > 1e-9 * (levels[-1] - levels[0])]
        if gaps.size == 0:
            continue
        step = float(gaps.min())
        k = (levels - levels[0]) / step
        if np.max(np.abs(k - np.round(k))) < 1e-2:
            out[j] = step
    return out


def _tapered_spectrum(q) -> tuple[np.ndarray, np.ndarray]:
    """Like `_rate_spectrum` through a Hann window, scaled so white noise keeps its mean.

    The window removes the leakage of the jump between the record's first and last Δq (a motion
    that does not end as it started), which otherwise fills the top of the spectrum like
    ``1/Ω²`` and hides a low noise floor (a quantised encoder's).
    """
    dq = np.diff(np.asarray(q, dtype=float), axis=0)
    if dq.ndim == 1:
        dq = dq[:, None]
    window = np.hanning(dq.shape[0])[:, None]
    power = np.abs(np.fft.rfft((dq - dq.mean(axis=0)) * window, axis=0)) ** 2
    power *= dq.shape[0] / max(float(np.sum(window**2)), 1e-300)
    freq = 2.0 * np.pi * np.fft.rfftfreq(dq.shape[0])
    return power, freq


def _floor(power: np.ndarray, freq: np.ndarray) -> np.ndarray:
    """σ̂ from a periodogram of Δq scaled so its mean is the variance density (`noise_floor`)."""
    high = freq > 0.6 * np.pi
    shape = 2.0 * (1.0 - np.cos(freq[high]))
    return np.sqrt(np.median(power[high] / shape[:, None], axis=0) / np.log(2.0))


def _spectrum_and_floor(arr: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The scaled periodogram of Δq, its frequencies, σ̂ and the quantisation step per column.

    On a quantised record (`quantisation_step`) the periodogram is tapered (`_tapered_spectrum`)
    and σ̂ is at least ``Δ/√12``, the standard deviation of rounding to a grid of step Δ (the
    rounding error is uniform on ``[-Δ/2, Δ/2]`` and white when q moves by more than Δ between
    samples; the floor is applied only to columns where most samples move, since a q that
    stays on one grid value rounds with a correlated, smaller error). Else both are as they
    always were.
    """
    step = quantisation_step(arr)
    if np.any(step > 0):
        power, freq = _tapered_spectrum(arr)
    else:
        power, freq = _rate_spectrum(arr)
    power = power / max(power.shape[0] * 2 - 2, 1)  # |rfft|² / n: the mean is the variance density
    moving = np.mean(np.abs(np.diff(arr, axis=0)) >= 0.5 * np.where(step > 0, step, np.inf), axis=0)
    floor = np.where(moving >= 0.5, step / np.sqrt(12.0), 0.0)
    sigma = np.maximum(_floor(power, freq), floor)
    return power, freq, sigma, step


def noise_floor(q) -> np.ndarray:
    """Standard deviation of white noise on each column of q, from the top of its spectrum.

    White noise of variance σ² on q gives Δq a periodogram of mean ``2σ²(1 - cos Ω)``; a smooth
    motion has almost no energy above Ω = 0.6π. The median over that band of
    ``P(Ω) / (2(1 - cos Ω))`` divided by ln 2 (the median of an exponential variable of mean 1)
    estimates σ² robustly against the few bins the motion still reaches. When q lies on a grid
    of step Δ (an encoder; `quantisation_step`) the periodogram is taken through a Hann window
    (the record's ends would otherwise leak into the top of the spectrum and hide the floor) and,
    where most samples move by Δ or more, σ̂ is at least ``Δ/√12``, the rounding error's
    standard deviation.

    Parameters
    ----------
    q : array_like, shape (n_samples, n_channels)

    Returns
    -------
    ndarray, shape (n_channels,)
        σ̂ per channel (the unit of q); about 0 for noise-free data.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 10, 10001)
    >>> q = np.sin(t)[:, None] + 1e-4 * np.random.default_rng(0).normal(size=(t.size, 1))
    >>> bool(abs(noise_floor(q)[0] / 1e-4 - 1) < 0.05)
    True
    """
    arr = np.asarray(q, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    return _spectrum_and_floor(arr)[2]


def white_floor(x) -> np.ndarray:
    """Standard deviation of white noise on each column of x (e.g. a measured torque).

    Like `noise_floor` but for noise on x itself: the median of x's periodogram above 0.6π,
    divided by ln 2. The columns are detrended by their end points first (a step between the
    first and the last sample would leak into every bin).

    Parameters
    ----------
    x : array_like, shape (n_samples, n_channels)

    Returns
    -------
    ndarray, shape (n_channels,)
    """
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    ramp = np.linspace(0.0, 1.0, arr.shape[0])[:, None]
    arr = arr - arr[:1] - ramp * (arr[-1:] - arr[:1])
    power = np.abs(np.fft.rfft(arr, axis=0)) ** 2 / arr.shape[0]
    freq = 2.0 * np.pi * np.fft.rfftfreq(arr.shape[0])
    return np.sqrt(np.median(power[freq > 0.6 * np.pi], axis=0) / np.log(2.0))


def _bands(arr: np.ndarray, threshold: float | None):
    """Steps 1–3 of `choose_filter`: the noise floor, the noise band and the signal band.

    Returns the energy threshold used, the signal band Ω_s and the noise band [rad/sample],
    whether the motion meets a noise floor below π/2, and the noise floor σ̂ and quantum of each
    channel.
    """
    power, freq, sigma, quantum = _spectrum_and_floor(arr)
    noise = 2.0 * (1.0 - np.cos(freq))[:, None] * sigma**2
    smooth = _smooth(power, max(1, power.shape[0] // 200))
    # 2. the noise band: per joint, the first frequency where the motion sinks below the noise
    #    (smoothed spectrum under twice the noise's); the highest of these over the joints
    buried = smooth < 2.0 * noise
    buried[0] = False
    first = np.where(buried.any(axis=0), np.argmax(buried, axis=0), freq.size - 1)
    noise_band = float(freq[int(first.max())])
    # 3. the signal band: energy of (smoothed - noise) up to the noise band. Without noise a
    #    wider band costs nothing, so it is drawn generously (CLEAN_FRACTION, 25 % margin):
    #    the nonlinear terms (velocity products) reach beyond the 1e-4 band of Δq.
    noisy = bool(noise_band < 0.5 * np.pi)
    signal = np.clip(smooth - noise, 0.0, None) * (freq <= noise_band)[:, None]
    total = signal.sum(axis=0)
    cumulative = np.cumsum(signal, axis=0) / np.where(total > 0, total, 1.0)

    def band(fraction: float, margin: float) -> float:
        edges = [
            float(freq[min(np.searchsorted(cumulative[:, j], 1.0 - fraction), freq.size - 1)])
            for j in range(arr.shape[1])
            if total[j] > 0
        ]
        return min(margin * max(edges, default=float(freq[1])), noise_band)

    if threshold is not None:
        signal_band = band(threshold, 1.0 if noisy else 1.25)
    elif not noisy:
        threshold, signal_band = CLEAN_FRACTION, band(CLEAN_FRACTION, 1.25)
    else:
        threshold, signal_band = ENERGY_FRACTION_WARN, band(ENERGY_FRACTION_WARN, 1.0)
        # A quantised q's noise is bounded and known (Δ/√12), so its noise band is reliable:
        # where the generous clean band still lies well below it (half), the motion there is
        # far above the noise and passing it costs little, while cutting it biases the
        # nonlinear terms (a sharp Coulomb friction reaches far beyond the 1e-4 band of Δq).
        wide = band(CLEAN_FRACTION, 1.25)
        if np.any(quantum > 0) and wide <= 0.5 * noise_band:
            threshold, signal_band = CLEAN_FRACTION, wide
    return threshold, signal_band, noise_band, noisy, sigma, quantum


def _lowest_cutoff(m: int, signal_band: float, dt: float) -> tuple[float, float]:
    """Step 5 of `choose_filter`: the lowest cut-off Ω_g whose flat band reaches Ω_s.

    The flat edge lies a nearly constant δ(M) ≈ 8π/(2M+1) below Ω_g, so two or three
    corrections of Ω_g suffice. Returns Ω_g and its flat edge.
    """
    cutoff = min(signal_band + 8.0 * np.pi / (2 * m + 1), np.pi)
    for _ in range(4):
        edge = passband_edge(m, cutoff, dt)
        step = cutoff / 800.0  # the resolution of passband_edge's grid
        if 0.0 <= edge - signal_band <= 2.0 * step or cutoff >= np.pi:
            break
        cutoff = float(np.clip(cutoff + (signal_band - edge) + step, step, np.pi))
    cutoff = float(cutoff)
    edge = passband_edge(m, cutoff, dt)
    return cutoff, edge


def _reason(m, cutoff, edge, threshold, signal_band, noise_band, noisy, sigma, quantum, half_width):
    """The sentence that says why `choose_filter` chose this filter."""
    why = (
        f"the motion's rate holds all but {threshold:g} of its energy below "
        f"{signal_band:.3g} rad/sample"
        + (
            f" and sinks into a noise floor of σ ≈ {np.max(sigma):.2g}"
            + (
                f" (q is quantised in steps of {np.max(quantum):.3g}: σ ≥ Δ/√12)"
                if np.any(quantum > 0)
                else ""
            )
            + f" above {noise_band:.3g} rad/sample"
            if noisy
            else ""
        )
        + (
            f"; M = {m} (the longest the record allows"
            if half_width is None
            else f"; M = {m} (given"
        )
    )
    return (
        f"filter M = {m}, Ω_g = {cutoff:.4g} rad/sample (flat to {edge:.3g}): {why}), Ω_g the "
        "lowest cut-off whose flat band holds that motion (lower would bias the fit, higher "
        "only adds noise)."
    )


def choose_filter(
    q,
    dt: float,
    *,
    half_width: int | None = None,
    max_half_width: int | None = None,
    threshold: float | None = None,
) -> FilterChoice:
    """Choose M and Ω_g from the data: the lowest-noise filter whose flat band holds the motion.

    1. The noise floor σ̂ of every q (`noise_floor`), and the signal part of the spectrum of Δq:
       the periodogram, smoothed, minus the noise's ``2σ̂²(1 - cos Ω)``.
    2. The noise band: above the highest frequency where the smoothed spectrum exceeds twice the
       noise's, there is nothing to pass but noise.
    3. The signal band Ω_s: the frequency below which all but ``threshold`` of the signal energy
       of Δq lies (worst joint), capped at the noise band (passing more adds only noise). On
       noise-free data a wider band costs nothing: the threshold is 1e-6 and Ω_s gets a 25 %
       margin, because the nonlinear terms (velocity products) reach beyond the band of Δq.
    4. M: as given, else as large as the record allows (``n / 20``, at most 1000 taps each side:
       2M samples are lost, and a longer filter has a narrower transition, so the same band needs a
       lower cut-off and lets less noise through; q̈^f's noise gain grows like Ω_g^2.5).
    5. Ω_g: the lowest cut-off whose flat band (`passband_edge`) reaches Ω_s.

    Parameters
    ----------
    q : array_like, shape (n_samples, n_channels)
        Joint angles [rad].
    dt : float [s]
        Sample period.
    half_width : int, optional
        Use this M and choose only Ω_g.
    max_half_width : int, optional
        Upper limit of M (default ``min(1000, n // 20)``, at least 10).
    threshold : float, optional
        Energy fraction of the signal allowed above the flat band. Default: ``1e-4``
        (``ENERGY_FRACTION_WARN``) on noisy data, ``1e-6`` (``CLEAN_FRACTION``) with a 25 %
        margin when no noise floor meets the motion below π/2.

    Returns
    -------
    FilterChoice

    Examples
    --------
    A 2 Hz motion sampled at 1 kHz with 1e-4 rad of noise:

    >>> import numpy as np
    >>> t = 1e-3 * np.arange(8000)
    >>> q = np.sin(2 * np.pi * 2 * t)[:, None]
    >>> q = q + 1e-4 * np.random.default_rng(1).normal(size=q.shape)
    >>> choice = choose_filter(q, 1e-3)
    >>> bool(choice.passband_edge >= choice.signal_band), choice.half_width
    (True, 400)
    """
    arr = np.asarray(q, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    n = arr.shape[0]
    threshold, signal_band, noise_band, noisy, sigma, quantum = _bands(arr, threshold)
    # 4. M
    if half_width is None:
        limit = max_half_width if max_half_width is not None else max(10, min(1000, n // 20))
        m = int(limit)
    else:
        m = int(half_width)
    cutoff, edge = _lowest_cutoff(m, signal_band, dt)
    reason = _reason(
        m, cutoff, edge, threshold, signal_band, noise_band, noisy, sigma, quantum, half_width
    )
    return FilterChoice(m, cutoff, edge, signal_band, noise_band, sigma, reason)
