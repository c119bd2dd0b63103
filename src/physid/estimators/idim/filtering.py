"""IDIM stage 1: the state filter, q -> (q^f, q̇^f, q̈^f) on the samples it keeps.

Arrays in, arrays out: `states` filters one recording's joint positions with physid's consistent
FIR bank (low-pass, d/dt, d²/dt²) or a zero-phase Butterworth and central differences (the
robotics standard), and returns the indices of the samples the filtered states belong to;
`auto_cutoff` chooses the cut-off from the spectrum of q.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import signal

from ..._validate import sample_period
from ...errors import SamplingError

__all__ = ["states", "auto_cutoff", "default_half_width", "DIFFERENTIATIONS"]

#: State-filter choices: physid's consistent FIR bank or the robotics standard.
DIFFERENTIATIONS = ("physid", "butterworth")


def butterworth_edge(cutoff: float) -> int:
    """Samples of the Butterworth filter's transient left out at each end [samples].

    Parameters
    ----------
    cutoff : float [rad/sample]

    Returns
    -------
    int
        ``ceil(6π/Ω)``: three periods of the cut-off (the central differences drop one more).
    """
    return int(math.ceil(6.0 * np.pi / cutoff))


def state_filter_drop(differentiation: str, cutoff: float, half_width: int | None) -> int:
    """Samples the state filter leaves out at each end of a recording [samples].

    Parameters
    ----------
    differentiation : {"physid", "butterworth"}
    cutoff : float [rad/sample]
    half_width : int or None
        M of the physid filter (given: the caller resolves the default first).

    Returns
    -------
    int
        physid: M. Butterworth: its transient (`butterworth_edge`) and the central
        difference's sample.
    """
    if differentiation == "physid":
        return int(half_width)
    return butterworth_edge(cutoff) + 1


def butterworth_states(q: np.ndarray, dt: float, cutoff: float, order: int = 4):
    """Zero-phase Butterworth (filtfilt) and central differences: the robotics standard.

    q̇_i = (q_{i+1} − q_{i−1}) / 2Δ,  q̈_i = (q_{i+1} − 2 q_i + q_{i−1}) / Δ²  on the filtered q.
    """
    sos = signal.butter(order, cutoff / np.pi, output="sos")
    edge = butterworth_edge(cutoff)  # the filter's transient at both ends
    qf = signal.sosfiltfilt(sos, q, axis=0, padlen=min(q.shape[0] - 1, edge))
    qd = (qf[2:] - qf[:-2]) / (2.0 * dt)
    qdd = (qf[2:] - 2.0 * qf[1:-1] + qf[:-2]) / dt**2
    idx = np.arange(1, q.shape[0] - 1)
    keep = slice(edge, idx.size - edge)
    return idx[keep], qf[1:-1][keep], qd[keep], qdd[keep]


def auto_cutoff(q: np.ndarray, *, ratio: float = 100.0, factor: float = 2.0) -> float:
    """A state-filter cut-off [rad/sample] from the spectrum of the joint positions.

    The band edge Ω_b is the highest frequency at which any joint's power spectral density
    (Welch, 4-term Blackman–Harris window: its −92 dB side lobes keep the leakage of the large
    low-frequency motion below the noise floor) stands ``ratio`` times above that joint's noise
    floor (the median of the upper half of the spectrum); the cut-off is ``factor · Ω_b``, kept in
    [0.005, 0.6] rad/sample.

    Parameters
    ----------
    q : ndarray, shape (n_samples, n_joints) [rad]
    ratio : float
        Signal-to-floor power ratio that still counts as motion.
    factor : float
        Margin between the band of the motion and the cut-off.

    Returns
    -------
    float [rad/sample]
    """
    n = q.shape[0]
    nperseg = int(min(n, 4096))
    f, p = signal.welch(
        q - q.mean(axis=0), window="blackmanharris", nperseg=nperseg, axis=0, detrend="linear"
    )
    omega = 2.0 * np.pi * f
    floor = np.median(p[omega > np.pi / 2], axis=0)
    edges = []
    for j in range(q.shape[1]):
        above = np.flatnonzero(p[:, j] > ratio * max(floor[j], 1e-300))
        edges.append(omega[above[-1]] if above.size else omega[1])
    edge = max(max(edges), omega[1])
    return float(np.clip(factor * edge, 0.005, 0.6))


def default_half_width(cutoff: float, n_samples: int) -> int:
    """FIR half-width M of the physid state filter when none is given.

    The transition band ≈ cutoff/2 (``M = ceil(8π / cutoff)``), at most 1/8 of a record of
    ``n_samples`` at each end, at least 2.
    """
    return max(2, min(int(math.ceil(8.0 * np.pi / cutoff)), n_samples // 8))


@functools.lru_cache(maxsize=16)
def consistent_bank(half_width: int, cutoff: float, dt: float):
    """physid's consistent FIR bank (low-pass, d/dt, d²/dt²), memoised (the taps are read-only)."""
    from ...filters.differential import design_filter_bank

    return design_filter_bank(half_width, cutoff, dt, design="consistent")


def states(q, dt, differentiation, cutoff, half_width):
    """Filtered q, q̇, q̈ of one recording and the indices of the samples they belong to.

    Parameters
    ----------
    q : ndarray, shape (n_samples, n_joints) [rad]
    dt : float [s]
    differentiation : {"physid", "butterworth"}
    cutoff : float [rad/sample]
    half_width : int or None
        M of the physid filter (`default_half_width` when None); unused by Butterworth.

    Returns
    -------
    idx : ndarray of int, shape (n,)
        The samples of ``q`` the filtered states belong to.
    qf, qdf, qddf : ndarray, shape (n, n_joints)
    m : int
        The half-width used (physid) or the Butterworth filter's edge [samples].
    """
    if differentiation == "physid":
        m = int(half_width) if half_width is not None else default_half_width(cutoff, q.shape[0])
        if q.shape[0] < 2 * m + 2:
            raise SamplingError(
                f"the recording has {q.shape[0]} samples, fewer than the state filter needs "
                f"(2·half_width + 1 = {2 * m + 1}, half_width={m} for cutoff={cutoff:.3g} "
                "rad/sample); use a longer recording, a higher cutoff or a smaller half_width."
            )
        t_idx = np.arange(q.shape[0], dtype=float) * dt
        # the same taps as filter_derivatives(q, t_idx, m, cutoff, design="consistent"), designed
        # once per (M, Ω, Δ): IV filters every simulated record with the fit's bank
        bank = consistent_bank(m, float(cutoff), sample_period(t_idx, "t"))
        value, first, second = (f.apply(q) for f in bank)
        idx = np.arange(m, q.shape[0] - m)
        return idx, value, first, second, m
    edge = butterworth_edge(cutoff)
    if q.shape[0] < 2 * edge + 10:
        raise SamplingError(
            f"the recording has {q.shape[0]} samples; the Butterworth state filter at "
            f"cutoff={cutoff:.3g} rad/sample needs more than {2 * edge + 10}. Use a longer "
            "recording or a higher cutoff."
        )
    idx, qf, qd, qdd = butterworth_states(q, dt, cutoff)
    return idx, qf, qd, qdd, edge
