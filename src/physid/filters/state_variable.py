"""State-variable filter (SVF): a causal Butterworth low-pass whose states are the derivatives.

The derivatives of a recorded signal come from one linear filter applied to every channel (in
`physid.estimators.recursive`, to *both* ``y`` and ``u``): if ``y`` and ``u`` satisfy a linear ODE
then so do ``F y`` and ``F u`` for any linear time-invariant ``F``, so the filter adds no bias (only
a decaying start-up term, which is discarded). ``F`` is an analog Butterworth low-pass of order
``N ≥ n + 1`` with unit DC gain, realised in controllable canonical form, whose states *are* the
filtered signal and its derivatives ``w, ẇ, …, w^(n)``; it is discretised exactly for a
piecewise-linear (first-order-hold) input.

`state_variable_filter` filters a whole record; `StreamingStateVariableFilter` carries the filter
state across chunks and reproduces the batch output for any chunking; `svf_transient_samples` says
how many start-up samples to discard.

References
----------
Young P. (1981), *Parameter estimation for continuous-time models — a survey*, Automatica 17(1).
Oueslati M. et al. (2011), section 3 (the pre-filter of the recursive estimator).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import linalg, signal

from .._validate import check_positive
from ..errors import InputError, ShapeError

__all__ = [
    "SVF_TRANSIENT_TOL",
    "state_variable_filter",
    "StreamingStateVariableFilter",
    "svf_transient_samples",
]

#: Relative decay of the slowest SVF mode after which the start-up transient counts as gone.
SVF_TRANSIENT_TOL = 1e-6


def _butterworth_svf(cutoff_hz: float, dt: float, filter_order: int):
    """Exact FOH discretisation of the Butterworth SVF; returns (per-derivative SOS list, poles).

    Continuous filter ``w^(N) + c_{N-1} w^(N-1) + … + c_0 w = c_0 v`` (unit DC gain) in controllable
    canonical form, state ``z = (w, ẇ, …, w^(N-1))``. For an input that is linear between samples,
    with ``E = expm([[A, B, 0], [0, 0, 1/dt], [0, 0, 0]] dt)``::

        z[k+1] = Φ z[k] + (Γa − Γb) v[k] + Γb v[k+1],   Φ = E[:N,:N], Γa = E[:N,N], Γb = E[:N,N+1]

    With ``ξ[k] = z[k] − Γb v[k]``: ``ξ[k+1] = Φ ξ[k] + (Φ Γb + Γa − Γb) v[k]`` and
    ``z[k] = ξ[k] + Γb v[k]``, a proper discrete system, converted per state to second-order
    sections (robust for poles close to 1).
    """
    omega_c = 2 * np.pi * cutoff_hz
    _, a_poly = signal.butter(filter_order, omega_c, analog=True)  # a_poly = [1, c_{N-1}, ..., c_0]
    a_poly = np.real(a_poly)
    n = filter_order
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1, :] = -a_poly[::-1][:-1]  # ż_N = −c_0 z_1 − c_1 z_2 − … − c_{N−1} z_N + c_0 v
    B = np.zeros(n)
    B[-1] = a_poly[-1]
    M = np.zeros((n + 2, n + 2))
    M[:n, :n] = A
    M[:n, n] = B
    M[n, n + 1] = 1.0 / dt
    E = linalg.expm(M * dt)
    Phi, gamma_a, gamma_b = E[:n, :n], E[:n, n], E[:n, n + 1]
    B_xi = Phi @ gamma_b + gamma_a - gamma_b
    sos_list = []
    for i in range(n):
        C = np.zeros((1, n))
        C[0, i] = 1.0
        z, p, k = signal.ss2zpk(Phi, B_xi[:, None], C, np.array([[gamma_b[i]]]))
        sos_list.append(signal.zpk2sos(z, p, k))
    analog_poles = np.roots(a_poly)
    return sos_list, analog_poles


def svf_transient_samples(cutoff: float, dt: float, filter_order: int) -> int:
    """Samples to discard at the start: the slowest Butterworth mode decays by `SVF_TRANSIENT_TOL`.

    ``ceil(ln(1 / 1e-6) / (σ_min dt))`` with ``σ_min = ω_c sin(π / (2N))`` [1/s] the smallest decay
    rate of the Butterworth poles (ω_c = 2π·cutoff).

    Parameters
    ----------
    cutoff : float [Hz]
        Butterworth cut-off.
    dt : float [s]
        Sample period.
    filter_order : int
        Butterworth order N.

    Returns
    -------
    int
        Number of samples [samples] after which the start-up transient is below 1e-6 of its
        initial size.

    Examples
    --------
    >>> svf_transient_samples(18.4, 1e-3, 3)
    240
    """
    sigma_min = 2 * np.pi * cutoff * np.sin(np.pi / (2 * filter_order))
    return int(math.ceil(math.log(1.0 / SVF_TRANSIENT_TOL) / (sigma_min * dt)))


def state_variable_filter(x, dt: float, cutoff: float, n_derivatives: int, filter_order=None):
    """Filtered signal and its first ``n_derivatives`` time derivatives (causal Butterworth SVF).

    Parameters
    ----------
    x : array_like, shape (n_samples,) or (n_samples, n_channels)
        Uniformly sampled signal.
    dt : float [s]
        Sample period.
    cutoff : float [Hz]
        Butterworth cut-off frequency; must be below the Nyquist frequency.
    n_derivatives : int
        Highest derivative returned, ``n``.
    filter_order : int, optional
        Butterworth order N ≥ n + 1 (default n + 1), so that ``w^(n)`` is a state (continuous).

    Returns
    -------
    ndarray, shape (n_samples, n_derivatives + 1) or (n_samples, n_channels, n_derivatives + 1)
        ``[..., i]`` is the i-th derivative of the filtered signal [unit / sᶦ], exact for signals
        that are linear between samples; the filter starts at rest, so discard the first
        `svf_transient_samples` samples unless the signal starts at rest too.

    Examples
    --------
    The filtered ramp's derivative settles to the slope (the filter has unit DC gain); the
    second derivative is zero up to rounding, which the states' gains (ω_c³ ≈ 2e6 s⁻³ here)
    raise to a few 1e-9:

    >>> t = np.arange(2000) * 1e-3
    >>> d = state_variable_filter(3.0 * t, 1e-3, cutoff=20.0, n_derivatives=2)
    >>> bool(np.allclose(d[-1, 1:], [3.0, 0.0], atol=2e-8))
    True
    """
    sos_list = _svf_design(dt, cutoff, n_derivatives, filter_order)
    arr = np.asarray(x, dtype=float)
    outs = [signal.sosfilt(sos, arr, axis=0) for sos in sos_list]
    return np.stack(outs, axis=-1)


def _svf_design(dt, cutoff, n_derivatives, filter_order):
    """Validated SOS of the SVF states ``w, ẇ, …, w^(n)`` (see `state_variable_filter`)."""
    dt = check_positive(dt, "dt")
    cutoff = check_positive(cutoff, "prefilter_cutoff")
    if cutoff >= 0.5 / dt:
        raise InputError(
            f"prefilter_cutoff must be below the Nyquist frequency {0.5 / dt:g} Hz; got "
            f"{cutoff:g} Hz. Lower it (a few times the system's natural frequency is typical)."
        )
    n_derivatives = int(n_derivatives)
    order = n_derivatives + 1 if filter_order is None else int(filter_order)
    if order < n_derivatives + 1:
        raise InputError(
            f"prefilter_order must be at least n + 1 = {n_derivatives + 1} so the "
            f"{n_derivatives}-th derivative of the filtered signal is a (continuous) filter "
            f"state; got {order}."
        )
    sos_list, _ = _butterworth_svf(cutoff, dt, order)
    return sos_list[: n_derivatives + 1]


class StreamingStateVariableFilter:
    """`state_variable_filter` fed chunk by chunk: carries the filter state across chunks.

    Each derivative's second-order sections keep their delay-line state (``sosfilt``'s ``zi``),
    so the concatenated outputs of any chunking equal the batch `state_variable_filter` of the
    whole signal (to rounding), with memory independent of the stream's length.

    Parameters
    ----------
    dt : float [s]
        Sample period.
    cutoff : float [Hz]
        Butterworth cut-off, below the Nyquist frequency.
    n_derivatives : int
        Highest derivative returned, ``n``.
    n_channels : int, default 1
        Channels filtered side by side (each chunk has shape (n_new, n_channels)).
    filter_order : int, optional
        Butterworth order N ≥ n + 1 (default n + 1).

    Examples
    --------
    Chunks of 7 samples reproduce the batch filter:

    >>> t = np.arange(300) * 1e-3
    >>> v = np.sin(20 * t)
    >>> svf = StreamingStateVariableFilter(1e-3, 20.0, 2)
    >>> chunks = [svf.update(v[i:i + 7]) for i in range(0, v.size, 7)]
    >>> batch = state_variable_filter(v, 1e-3, 20.0, 2)
    >>> bool(np.allclose(np.concatenate(chunks)[:, 0, :], batch, rtol=0, atol=1e-12))
    True
    """

    def __init__(
        self,
        dt: float,
        cutoff: float,
        n_derivatives: int,
        *,
        n_channels: int = 1,
        filter_order: int | None = None,
    ):
        self._sos = _svf_design(dt, cutoff, n_derivatives, filter_order)
        self.n_channels = int(n_channels)
        if self.n_channels < 1:
            raise InputError(f"n_channels must be >= 1; got {n_channels!r}.")
        self.reset()

    def reset(self) -> None:
        """Return the filter to rest (zero state), as at the start of `state_variable_filter`."""
        self._zi = [np.zeros((sos.shape[0], 2, self.n_channels)) for sos in self._sos]

    def update(self, chunk) -> np.ndarray:
        """Filter the next samples, shape (n_new,) or (n_new, n_channels).

        Returns
        -------
        ndarray, shape (n_new, n_channels, n_derivatives + 1)
            ``[..., i]``: the i-th derivative of the filtered signal [unit / sᶦ].
        """
        arr = np.asarray(chunk, dtype=float)
        if arr.ndim == 1:
            arr = arr[:, None]
        if arr.ndim != 2 or arr.shape[1] != self.n_channels:
            raise ShapeError(f"chunk must have shape (n_new, {self.n_channels}); got {arr.shape}.")
        outs = []
        for i, sos in enumerate(self._sos):
            out, self._zi[i] = signal.sosfilt(sos, arr, axis=0, zi=self._zi[i])
            outs.append(out)
        return np.stack(outs, axis=-1)
