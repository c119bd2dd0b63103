"""Measurement noise and disturbances: white noise at a given SNR or standard deviation, seeded.

Signal-to-noise ratio
---------------------
physid uses the definition of Oueslati et al. (2011, section 5), per channel, over the record::

    SNR [dB] = 10 log10( Σ_i x(t_i)² / Σ_i ρ(t_i)² )

i.e. the mean-square of the *clean* signal (not its variance: a signal with an offset counts the
offset as signal power, as MATLAB's ``awgn(x, snr, 'measured')`` does) over the mean-square of the
noise. `add_white_noise` draws Gaussian noise whose *expected* mean-square is
``mean(x²) / 10**(snr_db / 10)``; the realised SNR of one draw scatters around the request by about
``(10 / ln 10) · sqrt(2 / n)`` dB (0.012 dB at n = 10⁶ samples).

Random numbers come from `numpy.random.Generator`; ``rng`` may be ``None`` (fresh entropy), an
integer seed, a `numpy.random.SeedSequence` or a `Generator`. The same seed gives the same bits.
"""

from __future__ import annotations

import math

import numpy as np

from .._validate import as_1d, check_finite, check_positive
from ..errors import InputError, arg
from .excitation import sinusoid

__all__ = [
    "make_rng",
    "add_white_noise",
    "noise_std_for_snr",
    "snr_db",
    "sinusoidal_disturbance",
    "alias_frequency",
    "third_difference_sigma",
    "median_rows",
]

#: SNRs [dB] `noise_std_for_snr` accepts: wide enough for any experiment (double precision
#: resolves about 313 dB), narrow enough that 10**(snr/10) never overflows (it does at ~3083 dB).
SNR_RANGE_DB = (-300.0, 350.0)


def make_rng(rng=None) -> np.random.Generator:
    """Return a `numpy.random.Generator` from ``None``, an int seed, a SeedSequence or a Generator.

    Parameters
    ----------
    rng : None, int, SeedSequence, BitGenerator or Generator
        The source; a Generator is returned as is, None gives fresh entropy.

    Returns
    -------
    numpy.random.Generator
        The generator to draw from.

    Raises
    ------
    InputError
        If ``rng`` is of another type (e.g. a legacy ``np.random.RandomState``) or a negative int.
    """
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, (np.random.SeedSequence, np.random.BitGenerator)):
        return np.random.default_rng(rng)
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
        if rng < 0:
            raise InputError(f"seed must be a non-negative integer; got {rng}.")
        return np.random.default_rng(int(rng))
    raise InputError(
        "rng must be None, a non-negative int seed, a numpy SeedSequence or a numpy Generator; "
        f"got {rng!r} of type {type(rng).__name__}. Use np.random.default_rng(seed)."
    )


def _as_signal(x, name: str) -> np.ndarray:
    try:
        arr = np.array(x, dtype=float, copy=True)
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"{name} must be numeric; could not convert it to numbers ({exc})."
        ) from None
    if arr.ndim not in (1, 2) or arr.shape[0] == 0:
        raise InputError(
            f"{name} must have shape (n_samples,) or (n_samples, n_channels) with n_samples >= 1; "
            f"got shape {arr.shape}."
        )
    check_finite(arr.reshape(arr.shape[0], -1), name)
    return arr


def noise_std_for_snr(x, snr_db: float) -> np.ndarray:
    """Noise standard deviation per channel that gives the requested SNR in expectation.

    Parameters
    ----------
    x : array_like, shape (n_samples,) or (n_samples, n_channels)
        The clean signal (any unit).
    snr_db : float [dB]
        Requested signal-to-noise ratio, ``10 log10(Σ x² / Σ noise²)``.

    Returns
    -------
    std : ndarray, shape () or (n_channels,)
        ``sqrt(mean(x²) / 10**(snr_db / 10))`` in the unit of ``x``.

    Examples
    --------
    >>> float(noise_std_for_snr([1.0, -1.0, 1.0, -1.0], 20.0))  # mean(x²) = 1 -> σ² = 0.01
    0.1
    """
    arr = _as_signal(x, "x")
    try:
        snr = float(snr_db)
    except (TypeError, ValueError):
        raise InputError(f"snr_db must be a number in dB; got {snr_db!r}.") from None
    if not np.isfinite(snr):
        raise InputError(
            f"snr_db must be finite; got {snr_db!r}. Omit the noise instead of SNR = inf."
        )
    if not SNR_RANGE_DB[0] <= snr <= SNR_RANGE_DB[1]:
        # 10**(snr/10) overflows a double beyond ~3083 dB; long before that the noise is below
        # the rounding of the signal (double precision resolves ~313 dB) or swamps it entirely
        raise InputError(
            f"snr_db must lie in [{SNR_RANGE_DB[0]:g}, {SNR_RANGE_DB[1]:g}] dB; got {snr_db!r}. "
            "Above about 313 dB the noise is smaller than the rounding of the signal in double "
            "precision: omit the noise for a noise-free signal."
        )
    power = np.mean(arr**2, axis=0)
    if np.any(power == 0):
        raise InputError(
            "the signal is identically zero in at least one channel, so no noise level gives "
            "a finite SNR. Give the system a non-zero input, or give the noise as a standard "
            f"deviation instead ({arg('noise_std', '...', cli='STD')})."
        )
    return np.sqrt(power / 10.0 ** (snr / 10.0))


def add_white_noise(
    x, *, snr_db: float | None = None, std=None, rng=None
) -> tuple[np.ndarray, np.ndarray]:
    """Add zero-mean white Gaussian noise to a signal, at a given SNR or standard deviation.

    Parameters
    ----------
    x : array_like, shape (n_samples,) or (n_samples, n_channels)
        The clean signal (any unit); it is not modified.
    snr_db : float [dB], optional
        Signal-to-noise ratio per channel, ``10 log10(Σ x² / Σ noise²)`` over the record (the
        definition of Oueslati et al. 2011, section 5). Exactly one of ``snr_db`` and ``std``.
    std : float or array_like of shape (n_channels,), optional
        Noise standard deviation in the unit of ``x`` (one value, or one per channel).
    rng : None, int, numpy.random.SeedSequence or numpy.random.Generator
        Source of randomness; the same seed gives the same bits.

    Returns
    -------
    noisy : ndarray, same shape as x
        ``x + noise``.
    noise : ndarray, same shape as x
        The noise that was added.

    Examples
    --------
    >>> noisy, noise = add_white_noise(np.ones(4), std=0.0, rng=1)
    >>> noisy.tolist()
    [1.0, 1.0, 1.0, 1.0]
    """
    arr = _as_signal(x, "x")
    if (snr_db is None) == (std is None):
        raise InputError(
            "give exactly one of snr_db (signal-to-noise ratio in dB) and std (noise standard "
            f"deviation); got snr_db={snr_db!r} and std={std!r}."
        )
    if snr_db is not None:
        sigma = noise_std_for_snr(arr, snr_db)
    else:
        sigma = as_1d(std, "std")
        n_channels = 1 if arr.ndim == 1 else arr.shape[1]
        if sigma.size not in (1, n_channels):
            raise InputError(
                f"std must be one value or one per channel ({n_channels}); got {sigma.size} values."
            )
        for s in sigma:
            check_positive(s, "std", allow_zero=True)
        sigma = sigma[0] if (sigma.size == 1 or arr.ndim == 1) else sigma
    generator = make_rng(rng)
    noise = generator.standard_normal(arr.shape) * sigma
    return arr + noise, noise


def snr_db(x, noise) -> np.ndarray:
    """Realised SNR [dB] per channel, ``10 log10(Σ x² / Σ noise²)``.

    Parameters
    ----------
    x : array_like, shape (n_samples,) or (n_samples, n_channels)
        The clean signal.
    noise : array_like, same shape
        The noise added to it.

    Returns
    -------
    ndarray, shape (n_channels,) [dB]
        The SNR of each channel.
    """
    x = _as_signal(x, "x")
    noise = _as_signal(noise, "noise")
    if x.shape != noise.shape:
        raise InputError(f"x and noise must have the same shape; got {x.shape} and {noise.shape}.")
    return 10.0 * np.log10(np.sum(x**2, axis=0) / np.sum(noise**2, axis=0))


def sinusoidal_disturbance(
    t, amplitude: float, angular_frequency: float, phase: float = 0.0
) -> np.ndarray:
    """Additive sinusoidal disturbance ``amplitude · sin(angular_frequency · t + phase)``.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
    amplitude : float, in the unit of the disturbed signal (the paper's A2 = 0.1 m)
    angular_frequency : float [rad/s] (the paper's ω2 = 500 ω0)
    phase : float [rad]

    Returns
    -------
    ndarray, shape (n_samples,)

    Notes
    -----
    Sampled at period Δ, a sinusoid above the Nyquist frequency π/Δ is indistinguishable from one at
    `alias_frequency` (Oueslati et al.'s ω2 = 500 ω0 at 1 kHz appears at about 509.7 rad/s).
    """
    return sinusoid(t, amplitude, angular_frequency, phase)


def alias_frequency(angular_frequency: float, dt: float) -> float:
    """Apparent angular frequency [rad/s] of a sinusoid sampled at period ``dt`` [s].

    The sampled sequence ``sin(ω k Δ)`` equals ``± sin(ω_a k Δ)`` with
    ``ω_a = |ω − ω_s · round(ω / ω_s)|``, ``ω_s = 2π / Δ``, which lies in ``[0, π / Δ]``.

    Parameters
    ----------
    angular_frequency : float [rad/s]
        ω of the sinusoid.
    dt : float [s]
        Sample period Δ.

    Returns
    -------
    float [rad/s]
        The apparent frequency ω_a.

    Examples
    --------
    900 Hz sampled at 1 kHz looks like 100 Hz:

    >>> round(alias_frequency(2 * np.pi * 900.0, 1e-3) / (2 * np.pi), 6)
    100.0
    """
    omega = float(angular_frequency)
    period = check_positive(dt, "dt")
    if not np.isfinite(omega):
        raise InputError(f"angular_frequency must be finite; got {angular_frequency!r}.")
    omega_s = 2.0 * np.pi / period
    return float(abs(omega - omega_s * np.round(omega / omega_s)))


def third_difference_sigma(x) -> np.ndarray:
    """Robust white-noise std of each column: the MAD of the third difference over √20.

    White noise of std σ gives a third difference of std √20·σ, while a smooth motion sampled
    fast gives almost none: ``1.4826 · median(|d₃ − median(d₃)|) / √20`` per column, the
    medians by `median_rows` (``np.median``'s bit for bit). The noise level of measured
    positions (`physid.estimators._stiction.position_noise`), of raw torques
    (`physid.estimators.idim.verdict.torque_noise_sigma`) and of a streamed record's blocks.

    Parameters
    ----------
    x : array_like, shape (n_samples, n_channels)
        Samples [any unit].

    Returns
    -------
    ndarray, shape (n_channels,)
        Std [the unit of ``x``]; NaN for fewer than 4 samples.
    """
    d3 = np.ascontiguousarray(np.diff(np.asarray(x, dtype=float), n=3, axis=0).T)
    d3 -= median_rows(d3)[:, None]  # (channels, samples): each channel's values contiguous
    np.abs(d3, out=d3)
    return 1.4826 * median_rows(d3) / math.sqrt(20.0)


def median_rows(rows) -> np.ndarray:
    """Each row's median: ``np.median(rows, axis=1)`` bit for bit, in about half its time.

    Each row's middle order statistics are selected among the values between two bounds taken
    from a sorted sample of the row (every ``n // 1024``-th value, ±2√m sample ranks around its
    middle): counting the values below the lower bound gives their ranks, and only the ~10 %
    between the bounds are partitioned. Where the bounds miss (a rank outside them), the whole
    row is partitioned; where a value is neither below, between nor above them (NaN), the row's
    median is `np.median`'s (NaN). The mean of the two middle values of an even count is
    ``(a + b) / 2``, as `np.median` computes it.

    Parameters
    ----------
    rows : ndarray, shape (k, n)
        Values (finite for the speed-up), each row contiguous.

    Returns
    -------
    ndarray, shape (k,)
    """
    n = rows.shape[1]
    if n == 0:  # no values: np.median's NaN (and its warning)
        return np.median(rows, axis=1)
    h = n // 2
    ranks = [h - 1, h] if n % 2 == 0 else [h]
    out = np.empty(rows.shape[0])
    for j, row in enumerate(rows):  # per row (a channel: 14 for a 7-DOF arm's q and τ)
        sample = np.sort(row[:: max(1, n // 1024)])
        m = sample.size
        w = int(2.0 * math.sqrt(m)) + 2
        lo, hi = sample[max(m // 2 - w, 0)], sample[min(m // 2 + w, m - 1)]
        below = int(np.count_nonzero(row < lo))
        between = row[(row >= lo) & (row <= hi)]
        if below + between.size + int(np.count_nonzero(row > hi)) != n:  # a NaN: no order
            out[j] = np.median(row)
            continue
        if below <= ranks[0] and below + between.size > ranks[-1]:
            at = [r - below for r in ranks]
            v = np.partition(between, at)[at]
        else:  # the bounds missed a middle rank
            v = np.partition(row, ranks)[ranks]
        out[j] = (v[0] + v[1]) / 2.0 if v.size == 2 else v[0]
    return out
