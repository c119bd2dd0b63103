"""Inverse dynamic identification model (IDIM): least squares, weighted LS, instrumental variables.

The robotics way of identifying a rigid-body arm (Gautier, "Dynamic identification of robots
with power model", 1997; Gautier & Khalil 1990 for the base parameters; Janot, Vandanjon &
Gautier, "A generic instrumental variable approach for industrial robot identification", IEEE
TCST 2014, for IDIM-IV).

Pipeline (one recording at a time; several recordings are stacked *after* it, so that no filter
ever runs across the seam between two experiments)::

    q  ──► q^f, q̇^f, q̈^f                 (state filter: physid's consistent FIR bank, or a
                                           zero-phase Butterworth + central differences)
       ──► W = Y(q^f, q̇^f, q̈^f)[:, :, independent]      the base regressor (n, n_joints, p)
    [W | τ] ──► low-pass along time, keep one sample in nd      ("parallel filtering and
                                                                  decimation", every column)
       ──► β̂ = argmin ‖W β − τ‖²                (OLS; WLS: rows of joint j weighted by 1/σ̂_j)

The parallel filter (`scipy.signal.cheby1`, order 8, cut-off 0.8·π/nd rad/sample, run forwards and
backwards, as `scipy.signal.decimate` does) removes what lies above the band of the motion:
torque ripple, noise and the state filter's residual; decimation keeps the rows that carry
independent information. Because the same linear time-invariant filter is applied to every column
of W and to τ, ``τ = W β`` still holds exactly after it.

IDIM-IV replaces the noisy regressor in the normal equations by an instrument Z: the same base
regressor evaluated on a *simulated* closed loop of the current estimate (same PD controller,
same references ``r1..rn``), so that Z is correlated with W but not with the measurement noise:
``β̂_IV = (Zᵀ W)⁻¹ Zᵀ τ``, repeated with the new estimate until it stops changing.

Standard errors are a heteroscedasticity-and-autocorrelation-consistent (HAC) sandwich
(Newey & West 1987, Bartlett weights): the filters leave the decimated residual correlated over a
few rows and of different variance per joint, and the classical ``σ² (WᵀW)⁻¹`` then is too
optimistic. ``stderr="iid"`` gives the classical form (with a variance per joint when
``per_joint_variance=True``).
"""

from __future__ import annotations

import functools
import math
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import linalg, signal

from .._validate import check_int, check_positive, per_joint, sample_period
from ..errors import IdentifiabilityError, InputError, SamplingError, ShapeError, arg
from ._stiction import coulomb_joints, stuck_samples
from .base import EstimatorMixin
from .results import ResultMixin

__all__ = [
    "IDIMEstimator",
    "IDIMResult",
    "IDIMRows",
    "ConditionWarning",
    "idim_rows",
    "predict_torque",
    "parallel_decimate",
    "base_regressor_info",
    "hac_covariance",
    "condition_number",
    "METHODS",
]

#: Estimation methods of `IDIMEstimator`.
METHODS = ("ols", "wls", "iv")
#: State-filter choices: physid's consistent FIR bank or the robotics standard.
DIFFERENTIATIONS = ("physid", "butterworth")
#: Column-scaled condition number above which the fit warns (`ConditionWarning`) and above which
#: it refuses (an estimate is then meaningless).
COND_WARN = 1e3
COND_REFUSE = 1e8
#: A base-regressor column whose norm is below this fraction of the largest counts as unexcited.
UNEXCITED_RTOL = 1e-9
#: Relative torque error ``‖τ̂ − τ‖/‖τ‖`` on the fitted rows above which the fit reports
#: ``success=False``: overall, and for any single joint. A model that explains the data leaves
#: the noise and unmodelled effects: 5e-4 (planar2, σ_q = 1e-4 rad), 0.01 (arm6 README session),
#: 0.05–0.15 on real industrial arms in the literature; a wrong model or wrong data leaves far
#: more: 0.48 overall / 0.83 on tau2 for mean-removed q and τ (``--detrend``), 0.42 / 0.77 for
#: swapped joints (planar2, review F14).
REL_ERROR_FAIL = 0.2
REL_ERROR_FAIL_JOINT = 0.5
#: Integrator tolerances of IV's closed-loop simulations (the instruments). Looser than
#: `simulate_closed_loop`'s defaults (1e-9, 1e-11): half the right-hand-side evaluations, and on
#: arm7 (12 s, σ_q = 1e-3) the IV estimate moves by 6e-10 relative (measured), far below its
#: standard errors.
IV_RTOL = 1e-7
IV_ATOL = 1e-9


class ConditionWarning(UserWarning):
    """The base regressor is badly conditioned: the estimates will be poor; design the excitation."""


# ---------------------------------------------------------------------- base parameters
@dataclass(frozen=True)
class BaseInfo:
    """The base-parameter set of a model as IDIM uses it (see `base_regressor_info`).

    Attributes
    ----------
    names : tuple of str
        The base parameters' names as ``model.base_parameters()`` (and ``physid model info``)
        give them: the kept regressor column, with an ``R`` when other columns are regrouped
        into it (``"ZZ1R"``), so that a base value is never taken for the standard parameter of
        the same name. Models whose columns are monomials of their parameters (``"m3*l3"``)
        keep the kept column's name (no model takes it as a parameter).
    expressions : tuple of str
        Each base parameter as a combination of the standard ones, e.g. ``"ZZ1 + YY2 + ..."``.
    columns : ndarray of int, shape (p,)
        Indices of `independent` in the model's regressor columns.
    matrix : ndarray, shape (p, n_cols)
        K, with ``β_base = K β``.
    column_names : tuple of str
        The model's regressor column names (β).
    independent : tuple of str
        The regressor column kept for each base parameter (its leading term), e.g. ``"ZZ1"``.
    """

    names: tuple[str, ...]
    expressions: tuple[str, ...]
    columns: np.ndarray
    matrix: np.ndarray
    column_names: tuple[str, ...]
    independent: tuple[str, ...] = ()

    @property
    def n_base(self) -> int:
        """Number of base parameters p."""
        return len(self.names)

    def from_standard(self, beta) -> np.ndarray:
        """β_base = K β for a full vector of regressor parameters β, shape (n_cols,)."""
        return self.matrix @ np.asarray(beta, dtype=float)


def base_regressor_info(model) -> BaseInfo:
    """Base parameters of a model: kept columns, their expressions and the matrix K.

    Parameters
    ----------
    model : ChainModel
        A model with ``regressor``, ``beta_names`` (or ``regressor_names``) and
        ``base_parameters()``.

    Returns
    -------
    BaseInfo

    Raises
    ------
    InputError
        The model has no linear-in-parameters form.
    """
    for attr in ("regressor", "base_parameters"):
        if not hasattr(model, attr):
            raise InputError(
                f"IDIM needs a model that is linear in its base parameters (with {attr!r}); "
                f"{type(model).__name__} has none. Use the input-error method."
            )
    column_names = tuple(getattr(model, "regressor_names", None) or model.beta_names)
    bp = model.base_parameters()
    independent = tuple(bp.independent)
    expressions = tuple(getattr(bp, "expressions", None) or bp.base_names)
    base_names = tuple(getattr(bp, "base_names", None) or independent)
    names = independent if any(re.search(r"\s", n) for n in base_names) else base_names
    index = {n: i for i, n in enumerate(column_names)}
    columns = np.array([index[n] for n in independent], dtype=int)
    return BaseInfo(
        names,
        expressions,
        columns,
        np.asarray(bp.base_matrix, float),
        column_names,
        independent,
    )


# ---------------------------------------------------------------------- filters
def _decimation_sos(nd: int) -> np.ndarray:
    """The parallel filter: Chebyshev I, order 8, 0.05 dB ripple, cut-off 0.8/nd of Nyquist."""
    return signal.cheby1(8, 0.05, 0.8 / nd, output="sos")


@functools.lru_cache(maxsize=32)
def _decimated_noise_correlation(nd: int, lags: int = 8) -> np.ndarray:
    """Autocorrelation ``ρ_0..ρ_lags`` (ρ_0 = 1) of white noise after `parallel_decimate`: the
    zero-phase filter's autocorrelation sampled every ``nd`` samples (1, 0 … for nd = 1)."""
    out = np.zeros(lags + 1)
    out[0] = 1.0
    if nd <= 1:
        return out
    half = 40 * nd
    delta = np.zeros(2 * half + 1)
    delta[half] = 1.0
    g = signal.sosfiltfilt(_decimation_sos(nd), delta)
    r = np.correlate(g, g, "full")[g.size - 1 :]
    out[1:] = r[nd * np.arange(1, lags + 1)] / r[0]
    return out


def _decimation_edge(nd: int) -> int:
    """Samples dropped at each end after the parallel filter (its transient has died out)."""
    return 0 if nd <= 1 else int(12 * nd)


def parallel_decimate(x, nd: int, *, block_columns: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Low-pass every column of ``x`` (zero phase) and keep one row in ``nd``.

    Parameters
    ----------
    x : array_like, shape (n_samples, ...)
        Time on axis 0; any trailing shape (e.g. (n_joints, p) for a regressor).
    nd : int
        Decimation factor (1: no filter, no decimation).
    block_columns : int
        Columns filtered at a time (bounds the temporaries of `scipy.signal.sosfiltfilt`).

    Returns
    -------
    y : ndarray, shape (n_kept, ...)
        Filtered rows ``edge, edge + nd, ...`` (``edge = 12 nd`` samples of transient dropped at
        each end).
    kept : ndarray of int, shape (n_kept,)
        The input rows the output rows belong to.

    Notes
    -----
    The filter is Chebyshev type I of order 8 with cut-off ``0.8 π / nd`` rad/sample (the
    anti-aliasing filter of `scipy.signal.decimate`), in second-order sections, run forwards and
    backwards (zero phase; gain squared). Peak memory: one float64 copy of ``x`` plus a few
    copies of one block (``n_samples × block_columns``).
    """
    arr = np.asarray(x, dtype=float)
    n = arr.shape[0]
    nd = int(nd)
    if nd <= 1:
        return arr, np.arange(n)
    edge = _decimation_edge(nd)
    kept = np.arange(edge, n - edge, nd)
    flat = arr.reshape(n, -1)
    out = np.empty((kept.size, flat.shape[1]))
    sos = _decimation_sos(nd)
    padlen = min(n - 1, edge)
    for start in range(0, flat.shape[1], block_columns):
        cols = slice(start, start + block_columns)
        # time on the last, contiguous axis: scipy's sosfilt copies its input with time last,
        # which for axis=0 is a slow transposing copy (most of the cost); the filtering itself
        # is the same, sample by sample (bit-identical results)
        block = np.ascontiguousarray(flat[:, cols].T)
        out[:, cols] = signal.sosfiltfilt(sos, block, axis=-1, padlen=padlen)[:, kept].T
    return out.reshape((kept.size,) + arr.shape[1:]), kept


def _butterworth_states(q: np.ndarray, dt: float, cutoff: float, order: int = 4):
    """Zero-phase Butterworth (filtfilt) and central differences: the robotics standard.

    q̇_i = (q_{i+1} − q_{i−1}) / 2Δ,  q̈_i = (q_{i+1} − 2 q_i + q_{i−1}) / Δ²  on the filtered q.
    """
    sos = signal.butter(order, cutoff / np.pi, output="sos")
    edge = int(math.ceil(6.0 * np.pi / cutoff))  # the filter's transient at both ends
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


# ---------------------------------------------------------------------- rows of the regression
@dataclass(frozen=True, eq=False)
class IDIMRows:
    """The filtered, decimated regression ``τ = W β_base`` of one or more recordings.

    Attributes
    ----------
    W : ndarray, shape (n_rows, n_joints, p)
        Base regressor rows [N·m per unit of each base parameter].
    tau : ndarray, shape (n_rows, n_joints) [N·m]
        Filtered, decimated torques.
    t : ndarray, shape (n_rows,) [s]
        Time of each row.
    segments : ndarray of int, shape (n_rows,)
        Which recording each row comes from (0, 1, …).
    samples : ndarray of int, shape (n_rows,)
        Index of each row in its recording.
    cutoff : float [rad/sample]
        State-filter cut-off used.
    half_width : int
        FIR half-width M (physid filter) or the Butterworth edge.
    decimate : int
        nd.
    dt : float [s]
        Sample period of the recordings (the cut-off in rad/sample refers to it).
    stuck : ndarray of bool, shape (n_rows, n_joints), or None
        Equations dropped (their rows of ``W`` and ``tau`` set to zero) because the joint was
        at or near rest with Coulomb friction (``stick_threshold`` of `idim_rows`); None when
        nothing was dropped.
    """

    W: np.ndarray
    tau: np.ndarray
    t: np.ndarray
    segments: np.ndarray
    samples: np.ndarray
    cutoff: float
    half_width: int
    decimate: int
    dt: float = float("nan")
    stuck: np.ndarray | None = None


def _recording_arrays(recording, n_joints: int, torque: bool = True):
    names = list(recording.names)
    q_names = [f"q{j + 1}" for j in range(n_joints)]
    tau_names = [f"tau{j + 1}" for j in range(n_joints)]
    if not torque and not any(c in names for c in tau_names):
        tau_names = []  # prediction from the motion alone
    missing = [c for c in q_names + tau_names if c not in names]
    if missing:
        raise InputError(
            f"the recording lacks channel(s) {missing}; IDIM needs q1..q{n_joints} [rad] and "
            f"tau1..tau{n_joints} [N·m] (it has {names}). Map them with "
            f"{arg('channels', '{NAME: COLUMN}', cli='q1=COLUMN,...')}."
        )
    extra = [
        c
        for c in names
        if re.fullmatch(r"(q|tau)(\d+)", c) and int(re.fullmatch(r"\D+(\d+)", c)[1]) > n_joints
    ]
    if extra:
        raise ShapeError(
            f"the recording has channel(s) {extra} beyond the model's {n_joints} joints; "
            "check that the recording belongs to this model."
        )
    t = np.asarray(recording.t, dtype=float)
    tau = recording.select(tau_names) if tau_names else np.zeros((t.size, n_joints))
    return t, recording.select(q_names), tau


@functools.lru_cache(maxsize=16)
def _consistent_bank(half_width: int, cutoff: float, dt: float):
    """physid's consistent FIR bank (low-pass, d/dt, d²/dt²), memoised (the taps are read-only)."""
    from ..filters.differential import design_filter_bank

    return design_filter_bank(half_width, cutoff, dt, design="consistent")


def _states(q, dt, differentiation, cutoff, half_width):
    """Filtered q, q̇, q̈ and the indices of the samples they belong to."""
    if differentiation == "physid":
        if half_width is not None:
            m = int(half_width)
        else:  # transition band ≈ cutoff/2, at most 1/8 of the record at each end
            m = max(2, min(int(math.ceil(8.0 * np.pi / cutoff)), q.shape[0] // 8))
        if q.shape[0] < 2 * m + 2:
            raise SamplingError(
                f"the recording has {q.shape[0]} samples, fewer than the state filter needs "
                f"(2·half_width + 1 = {2 * m + 1}, half_width={m} for cutoff={cutoff:.3g} "
                "rad/sample); use a longer recording, a higher cutoff or a smaller half_width."
            )
        t_idx = np.arange(q.shape[0], dtype=float) * dt
        # the same taps as filter_derivatives(q, t_idx, m, cutoff, design="consistent"), designed
        # once per (M, Ω, Δ): IV filters every simulated record with the fit's bank
        bank = _consistent_bank(m, float(cutoff), sample_period(t_idx, "t"))
        value, first, second = (f.apply(q) for f in bank)
        idx = np.arange(m, q.shape[0] - m)
        return idx, value, first, second, m
    edge = int(math.ceil(6.0 * np.pi / cutoff))
    if q.shape[0] < 2 * edge + 10:
        raise SamplingError(
            f"the recording has {q.shape[0]} samples; the Butterworth state filter at "
            f"cutoff={cutoff:.3g} rad/sample needs more than {2 * edge + 10}. Use a longer "
            "recording or a higher cutoff."
        )
    idx, qf, qd, qdd = _butterworth_states(q, dt, cutoff)
    return idx, qf, qd, qdd, edge


def _base_regressor(model, info: BaseInfo, q, qd, qdd, block: int = 8192) -> np.ndarray:
    """W = Y(q, q̇, q̈)[:, :, independent], evaluated in blocks of samples.

    Peak memory: the base regressor (n, n_joints, p) plus one block of the full regressor
    (block, n_joints, n_cols).
    """
    n = q.shape[0]
    out = np.empty((n, q.shape[1], info.n_base))
    for s in range(0, n, block):
        sl = slice(s, s + block)
        out[sl] = np.asarray(model.regressor(q[sl], qd[sl], qdd[sl]), dtype=float)[
            :, :, info.columns
        ]
    return out


def idim_rows(
    model,
    recordings,
    *,
    info: BaseInfo | None = None,
    differentiation: str = "physid",
    cutoff: float | str = "auto",
    half_width: int | None = None,
    decimate: int | str = "auto",
    torque: bool = True,
    stick_threshold: float = 0.0,
) -> IDIMRows:
    """Build the filtered, decimated IDIM regression of one or several recordings.

    Parameters
    ----------
    model : ChainModel
    recordings : Recording or sequence of Recording
        Each with ``t`` [s], ``q1..qn`` [rad], ``tau1..taun`` [N·m]; same joints, same period.
    info : BaseInfo, optional
        From `base_regressor_info` (computed when not given).
    differentiation : {"physid", "butterworth"}
        State filter: physid's consistent FIR bank (`physid.filters.filter_derivatives`,
        ``design="consistent"``), or a 4th-order zero-phase Butterworth with central differences.
    cutoff : float [rad/sample] or "auto"
        State-filter cut-off Ω = 2π f Δ; "auto": `auto_cutoff` on the first recording.
    half_width : int, optional
        FIR half-width M of the physid filter (default ``ceil(8π / cutoff)``).
    decimate : int or "auto"
        nd; "auto": ``floor(1.6 π / cutoff)``, so that the parallel filter's cut-off
        (0.8 π / nd) sits at half the state filter's, where the FIR bank is flat (on the paper's
        arm with σ_q = 1e-4 rad this halves the held-out torque error of nd = 0.8 π / cutoff),
        lowered when fewer than 20 equations per base parameter would remain.
    torque : bool
        False: a recording may lack ``tau1..taun`` (for a prediction from the motion alone);
        ``tau`` of the rows is then zero.
    stick_threshold : float
        Drop joint j's equations where its filtered speed |q̇_j| is below ``stick_threshold``
        times its rms (and within the parallel filter's reach of such a sample), for joints with
        Coulomb friction (``Fc{j}``) only. While a joint sticks the friction torque holding it
        lies anywhere in [−Fc, Fc], but the regressor writes Fc·sign(0) = 0, and the filters
        smear each stick/slip switch; those equations are wrong, not noisy. 0 (the default here)
        keeps every equation; `IDIMEstimator` uses 0.05.

    Returns
    -------
    IDIMRows

    Raises
    ------
    ShapeError, SamplingError, InputError
        Recordings with other joints or sampling periods than the first one, too short for the
        filters, or bad settings.
    """
    from ..signals.recording import Recording

    if isinstance(recordings, Recording):
        recordings = [recordings]
    recordings = list(recordings)
    if not recordings:
        raise InputError("recordings must hold at least one Recording; got none.")
    if differentiation not in DIFFERENTIATIONS:
        raise InputError(
            f"differentiation must be one of {DIFFERENTIATIONS}; got {differentiation!r}."
        )
    info = info or base_regressor_info(model)
    nj = int(model.n_joints)
    arrays = [_recording_arrays(r, nj, torque) for r in recordings]
    dts = [sample_period(t, "t") for t, _, _ in arrays]
    for k, dt in enumerate(dts[1:], start=1):
        if not math.isclose(dt, dts[0], rel_tol=1e-6):
            raise SamplingError(
                f"recording {k + 1} has sample period {dt:.9g} s, recording 1 has {dts[0]:.9g} s; "
                "stacked recordings must share one period. Resample them to a common period "
                f"first (Recording.resample, or {arg('resample', 'True', cli='')} when loading)."
            )
    names0 = [c for c in recordings[0].names if re.fullmatch(r"(q|tau)\d+", c)]
    for k, r in enumerate(recordings[1:], start=1):
        names_k = [c for c in r.names if re.fullmatch(r"(q|tau)\d+", c)]
        if sorted(names_k) != sorted(names0):
            raise ShapeError(
                f"recording {k + 1} has joint channels {sorted(names_k)}, recording 1 has "
                f"{sorted(names0)}; stacked recordings must have the same joints."
            )
    if isinstance(cutoff, str):
        if cutoff != "auto":
            raise InputError(
                f"{arg('cutoff')} must be a number [rad/sample] or 'auto'; got {cutoff!r}."
            )
        cutoff = auto_cutoff(arrays[0][1])
    try:
        cutoff = float(cutoff)
    except (TypeError, ValueError):
        cutoff = float("nan")
    if not 0.0 < cutoff <= np.pi:
        raise InputError(f"{arg('cutoff')} must lie in (0, π] rad/sample; got {cutoff!r}.")
    half_width = check_int(half_width, "half_width", minimum=1, allow_none=True)
    if half_width is None and differentiation == "physid":
        # one M for every recording (the instruments of IDIM-IV and `validate` reuse it):
        # transition band ≈ cutoff/2, at most 1/8 of the shortest record at each end
        n_short = min(a[0].size for a in arrays)
        half_width = max(2, min(int(math.ceil(8.0 * np.pi / cutoff)), n_short // 8))
    if isinstance(decimate, str):
        if decimate != "auto":
            raise InputError(
                f"{arg('decimate')} must be a positive integer or 'auto'; got {decimate!r}."
            )
        decimate = max(1, int(math.floor(1.6 * np.pi / cutoff)))
        n_min = 0.75 * min(a[0].size for a in arrays)  # after the state filter
        rows_needed = max(20.0 * info.n_base / nj, 50.0)
        decimate = max(1, min(decimate, int(n_min / (rows_needed + 24.0))))
    nd = check_int(decimate, "decimate", minimum=1)
    stick_threshold = float(stick_threshold)
    if not (np.isfinite(stick_threshold) and 0.0 <= stick_threshold < 1.0):
        raise InputError(
            f"{arg('stick_threshold')} must be a fraction of the rms speed in [0, 1); got "
            f"{stick_threshold!r}."
        )
    coulomb = coulomb_joints(model)
    drop = stick_threshold > 0 and bool(coulomb.any())

    Ws, taus, ts, segs, samples, stucks = [], [], [], [], [], []
    m_used = 0
    for k, (t, q, tau) in enumerate(arrays):
        idx, qf, qdf, qddf, m_used = _states(q, dts[k], differentiation, cutoff, half_width)
        if drop:
            stucks_full = stuck_samples(qdf, coulomb, stick_threshold, _decimation_edge(nd))
        W = _base_regressor(model, info, qf, qdf, qddf)
        stacked = np.concatenate([W.reshape(W.shape[0], -1), tau[idx]], axis=1)
        if stacked.shape[0] <= 2 * _decimation_edge(nd) + 1:
            raise SamplingError(
                f"recording {k + 1}: after the state filter {stacked.shape[0]} samples remain, "
                f"too few for decimate={nd} (the parallel filter drops {_decimation_edge(nd)} at "
                "each end); use a smaller decimate or a longer recording."
            )
        dec, kept = parallel_decimate(stacked, nd)
        p = info.n_base
        Wk = dec[:, : nj * p].reshape(-1, nj, p)
        tauk = dec[:, nj * p :]
        if drop:
            stuck = stucks_full[kept]
            Wk[stuck] = 0.0  # joint j's equation at that row: no information, no weight
            tauk[stuck] = 0.0
            stucks.append(stuck)
        Ws.append(Wk)
        taus.append(tauk)
        ts.append(t[idx[kept]])
        segs.append(np.full(kept.size, k))
        samples.append(idx[kept])
    return IDIMRows(
        W=np.concatenate(Ws),
        tau=np.concatenate(taus),
        t=np.concatenate(ts),
        segments=np.concatenate(segs),
        samples=np.concatenate(samples),
        cutoff=cutoff,
        half_width=int(m_used),
        decimate=nd,
        dt=float(dts[0]),
        stuck=np.concatenate(stucks) if drop else None,
    )


# ---------------------------------------------------------------------- linear algebra
def condition_number(W) -> float:
    """Condition number of a regressor with its columns scaled to unit norm.

    Parameters
    ----------
    W : array_like, shape (n_rows, ..., p)
        Rows of the regression (all leading axes are rows).

    Returns
    -------
    float
        ``σ_max / σ_min`` of ``W D`` with ``D`` making every column unit norm (inf if singular).
        Scaling makes the number independent of the units of the parameters.
    """
    a = np.asarray(W, dtype=float)
    a = a.reshape(-1, a.shape[-1])
    norms = np.linalg.norm(a, axis=0)
    if np.any(norms == 0):
        return float("inf")
    s = np.linalg.svd(a / norms, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def _newey_west_lag(n_rows: int) -> int:
    """Newey–West plug-in lag ``floor(4 (T/100)^(2/9))``."""
    return int(math.floor(4.0 * (n_rows / 100.0) ** (2.0 / 9.0)))


def _correlation_length(e: np.ndarray, segments: np.ndarray) -> int:
    """First lag at which the mean (over joints) residual autocorrelation drops below 0.1."""
    seg0 = e[segments == segments[0]]
    x = seg0 - seg0.mean(axis=0)
    n = x.shape[0]
    nfft = 1 << int(math.ceil(math.log2(2 * n)))
    spec = np.abs(np.fft.rfft(x, nfft, axis=0)) ** 2
    acf = np.fft.irfft(spec, nfft, axis=0)[:n]
    acf = acf / np.where(acf[0] > 0, acf[0], 1.0)
    mean_acf = acf.mean(axis=1)
    below = np.flatnonzero(mean_acf < 0.1)
    return int(below[0]) if below.size else n // 4


def hac_covariance(scores, bread_inv, segments=None, lag: int | None = None) -> np.ndarray:
    """Newey–West (Bartlett) sandwich ``A⁻¹ S A⁻ᵀ`` for a (possibly IV) least-squares estimate.

    Parameters
    ----------
    scores : array_like, shape (n_rows, p)
        Per time row, the sum over joints of instrument × residual, ``g_t = Σ_j Z_tj e_tj``.
    bread_inv : array_like, shape (p, p)
        ``A⁻¹`` with ``A = Zᵀ W`` (``WᵀW`` for OLS).
    segments : array_like of int, shape (n_rows,), optional
        Recording of each row: lags never pair rows of two recordings.
    lag : int, optional
        Bandwidth L (Bartlett weights ``1 − l/(L+1)``); default: Newey–West's plug-in.

    Returns
    -------
    ndarray, shape (p, p)
        ``A⁻¹ (Σ_{|l|≤L} w_l Γ_l) A⁻ᵀ``, ``Γ_l = Σ_t g_t g_{t−l}ᵀ``.
    """
    g = np.asarray(scores, dtype=float)
    n = g.shape[0]
    seg = np.zeros(n, dtype=int) if segments is None else np.asarray(segments)
    lag = _newey_west_lag(n) if lag is None else int(lag)
    S = g.T @ g
    for ell in range(1, lag + 1):
        same = seg[ell:] == seg[:-ell]
        gamma = (g[ell:] * same[:, None]).T @ g[:-ell]
        S += (1.0 - ell / (lag + 1.0)) * (gamma + gamma.T)
    B = np.asarray(bread_inv, dtype=float)
    return B @ S @ B.T


# ---------------------------------------------------------------------- result
@dataclass(frozen=True)
class ConsistentEstimate:
    """A physically consistent estimate (see `IDIMEstimator` with ``consistent=True``).

    Attributes
    ----------
    standard : dict name -> float
        Standard parameters (10 per link, then drive terms) of a physically realisable arm.
    base : dict name -> float
        Its base parameters.
    cost_ratio : float
        ``‖W β_c − τ‖² / ‖W β̂ − τ‖²`` on the fitted (weighted) rows: the price of consistency
        (≥ 1 for OLS/WLS; an IV estimate is not the least-squares solution, so it can be < 1).
    at_boundary : tuple of str
        Links whose pseudo-inertia is (numerically) singular, and friction terms at zero.
    min_eigenvalues : dict link -> float
        Smallest eigenvalue of each link's pseudo-inertia [kg·m²].
    message : str
    converged : bool
        Whether the solver reached its duality-gap target (else `message` says why, and the
        IDIM result reports ``success=False``).
    """

    standard: dict[str, float]
    base: dict[str, float]
    cost_ratio: float
    at_boundary: tuple[str, ...]
    min_eigenvalues: dict[str, float]
    message: str
    converged: bool = True


@dataclass(frozen=True)
class IDIMResult(ResultMixin):
    """Estimates of an IDIM fit (OLS, WLS or IV) of the base parameters.

    Attributes
    ----------
    names : tuple of str
        Base parameters as ``model.base_parameters()`` names them: ``"ZZ1R"`` when other
        columns are regrouped into the kept column ``ZZ1`` (see `BaseInfo.names`). A model's
        ``params=`` refuses these names: they are not standard parameters.
    parameters : dict name -> float
        Base-parameter estimates (SI units).
    expressions : dict name -> str
        What each base parameter is, as a combination of the standard parameters.
    columns : tuple of str
        The regressor column kept for each base parameter (``"ZZ1"``), in the order of `names`.
    stderr : dict name -> float or None
        Standard errors (`stderr_method`), or None with `stderr_reason`.
    stderr_reason : str or None
    stderr_method : str
        ``"hac"`` (Newey–West sandwich, lag `hac_lag`) or ``"iid"``.
    covariance : ndarray, shape (p, p)
    derived : dict
        With ``consistent=True``: the standard parameters of the consistent estimate.
    units : dict name -> str
    method : str
        ``"idim-ols"``, ``"idim-wls"`` or ``"idim-iv"``.
    success : bool
    message : str
    condition_number : float
        Column-scaled condition number of the (weighted) base regressor.
    relative_error : dict
        ``‖τ̂ − τ‖ / ‖τ‖`` on the fitted (filtered, decimated) rows: ``"overall"`` and
        ``"tau1"``… per joint.
    joint_sigma : dict
        Residual standard deviation per joint [N·m] (the WLS weights are their inverses).
    n_rows : int
        Decimated time rows used (each holds n_joints equations).
    n_recordings : int
    cutoff : float [rad/sample]
    half_width : int
    decimate : int
    dt : float [s]
        Sample period of the fitted recordings (`cutoff` is in rad/sample of this period).
    differentiation : str
    iterations : int
        IV iterations (0 for OLS/WLS).
    iv_changes : tuple of float
        Relative change of the estimate per IV iteration.
    consistent : ConsistentEstimate or None
    warnings : tuple of str
    history : ndarray, shape (n_steps, p)
        The estimate after each step (OLS, then WLS/IV iterations).
    t : ndarray, shape (n_rows,) [s]
    residuals : ndarray, shape (n_rows, n_joints) [N·m]
    model : ChainModel or None
        The model fitted (used by `predict`; not written by ``to_dict``).
    stick_threshold : float or None
        The fit's ``stick_threshold`` (`validate` drops the same near-rest rows).
    """

    names: tuple[str, ...]
    parameters: dict[str, float]
    expressions: dict[str, str]
    columns: tuple[str, ...]
    stderr: dict[str, float] | None
    stderr_reason: str | None
    stderr_method: str
    covariance: np.ndarray
    derived: dict[str, float]
    units: dict[str, str]
    method: str
    success: bool
    message: str
    condition_number: float
    relative_error: dict[str, float]
    joint_sigma: dict[str, float]
    n_rows: int
    n_recordings: int
    cutoff: float
    half_width: int
    decimate: int
    dt: float
    differentiation: str
    hac_lag: int
    iterations: int
    iv_changes: tuple[float, ...]
    consistent: ConsistentEstimate | None
    warnings: tuple[str, ...]
    history: np.ndarray = field(repr=False)
    t: np.ndarray = field(repr=False)
    residuals: np.ndarray = field(repr=False)
    model: Any = field(default=None, repr=False, compare=False)
    stick_threshold: float | None = None

    _history_fields = ("history", "t", "residuals", "covariance")
    _private_fields = ("model",)
    _unpicklable_fields = ("model",)  # compiled kernels (ctypes): pickled as None

    def beta_vector(self) -> np.ndarray:
        """The estimates as an array ordered like `names`."""
        return np.array([self.parameters[n] for n in self.names])

    def summary(self) -> str:
        """Estimates ± standard errors, the condition number, the relative torque errors."""
        lines = [super().summary()]
        lines.append(
            f"  condition number {self.condition_number:.4g}; relative torque error "
            f"{self.relative_error['overall']:.4g} overall ("
            + ", ".join(f"{k} {v:.3g}" for k, v in self.relative_error.items() if k != "overall")
            + f"); {self.n_rows} rows, decimate {self.decimate}, cutoff {self.cutoff:.3g} "
            "rad/sample"
        )
        if self.iterations:
            lines.append(
                f"  IV: {self.iterations} iterations, relative change per iteration "
                + ", ".join(f"{c:.2g}" for c in self.iv_changes)
            )
        if self.consistent is not None:
            c = self.consistent
            lines.append(
                f"  consistent estimate: cost ratio {c.cost_ratio:.4g}; at the boundary: "
                + (", ".join(c.at_boundary) or "none")
            )
        return "\n".join(lines)

    def predict_rows(self, rows: IDIMRows) -> np.ndarray:
        """τ̂ = W β̂ on rows built like the fit's (`idim_rows`), shape (n_rows, n_joints)."""
        return rows.W @ self.beta_vector()

    def predict(self, recording, *, measured: bool = False):
        """Torques the identified base parameters predict from a recording's motion.

        The recording's q goes through the fit's own state filter (`differentiation`,
        `cutoff`, `half_width`) and the base regressor through the fit's parallel filter and
        decimation (`decimate`): the prediction is ``τ̂ = W β̂`` on the *filtered, decimated
        rows* (the robotics convention for the cross-test), not at every input sample. See
        `predict_torque`.

        Parameters
        ----------
        recording : Recording
            ``t`` [s] and ``q1..qn`` [rad | m], sampled like the fit's recordings;
            ``tau1..taun`` are needed only with ``measured=True``.
        measured : bool
            Also return the recording's torques through the same filter and decimation, as
            channels ``tau1_measured..``.

        Returns
        -------
        Recording
            Time of the kept rows [s]; ``tau1..taun`` predicted [N·m | N] (and the measured
            ones); ``metadata`` records the filter settings and ``"prediction"``.

        Raises
        ------
        InputError
            The result holds no model (a result built by hand): use `predict_torque`.
        """
        if self.model is None:
            raise InputError(
                "this IDIMResult holds no model; call "
                "physid.estimators.idim.predict_torque(model, result.names, "
                "result.beta_vector(), recording, ...) instead."
            )
        return predict_torque(
            self.model,
            self.names,
            self.beta_vector(),
            recording,
            differentiation=self.differentiation,
            cutoff=self.cutoff,
            half_width=self.half_width,
            decimate=self.decimate,
            measured=measured,
        )


def predict_torque(
    model,
    names,
    beta,
    recording,
    *,
    differentiation: str = "physid",
    cutoff: float | str = "auto",
    half_width: int | None = None,
    decimate: int | str = "auto",
    measured: bool = False,
):
    """τ̂ = W β on a recording's rows, filtered and decimated as `idim_rows` builds them.

    Parameters
    ----------
    model : ChainModel
        The model the base parameters belong to.
    names : sequence of str
        Base-parameter names (``IDIMResult.names``); must be the model's base set.
    beta : array_like, shape (p,)
        Base-parameter values in the order of ``names``.
    recording : Recording
        ``t`` [s], ``q1..qn`` [rad | m] (``tau1..taun`` [N·m | N] with ``measured=True``).
    differentiation, cutoff, half_width, decimate :
        The fit's filter settings (see `idim_rows`; ``IDIMResult`` records them).
    measured : bool
        Also return the recording's torques through the same filter and decimation
        (channels ``tau1_measured..``).

    Returns
    -------
    Recording
        ``tau1..taun`` predicted at the kept rows (time ``t`` of those rows), optionally
        followed by ``tau1_measured..``; ``metadata["prediction"]`` says what was computed.
        Peak memory: one float64 copy of the base regressor (n_samples × n_joints × p).

    Raises
    ------
    InputError
        ``names`` is not the model's base set, or ``beta`` has another length; the recording
        lacks a channel.
    """
    from ..signals.recording import Recording

    if not isinstance(recording, Recording):
        raise InputError(
            f"recording must be one Recording; got {type(recording).__name__}. Predict each "
            "recording on its own."
        )
    info = base_regressor_info(model)
    names = tuple(names)
    beta = np.asarray(beta, dtype=float).ravel()
    if names == info.independent:  # result files written before wave 3 keyed the kept columns
        names = info.names
    if names != info.names or beta.size != len(names):
        raise InputError(
            f"the result has {len(names)} base parameters ({list(names)[:4]}…) and {beta.size} "
            f"values, but the model {getattr(model, 'name', '')!r} has {info.n_base} "
            f"({list(info.names)[:4]}…); predict with the model the result was fitted with."
        )
    nj = int(model.n_joints)
    has_tau = all(f"tau{j + 1}" in recording.names for j in range(nj))
    if measured and not has_tau:
        raise InputError(
            f"measured=True needs the torque channels tau1..tau{nj} in the recording; it has "
            f"{list(recording.names)}."
        )
    rows = idim_rows(
        model,
        recording,
        info=info,
        differentiation=differentiation,
        cutoff=cutoff,
        half_width=half_width,
        decimate=decimate,
        torque=False,
    )
    return torque_recording(
        model,
        rows.t,
        rows.W @ beta,
        rows.tau if measured else None,
        metadata={
            "prediction": "inverse model tau = W beta on the rows filtered and decimated as in "
            "the fit",
            "differentiation": differentiation,
            "cutoff": rows.cutoff,
            "half_width": rows.half_width,
            "decimate": rows.decimate,
        },
    )


def torque_recording(model, t, tau_hat, tau_measured=None, *, metadata=None):
    """A predicted-torque `Recording`: ``tau1..taun`` [N·m, N on prismatic joints], then
    ``tau1_measured..`` when ``tau_measured`` (same shape as ``tau_hat``) is given.

    The one output shape of every inverse-model prediction (IDIM's `predict_torque`,
    input-error's `physid.estimators.input_error.prepare.predict_torque`).
    """
    from ..signals.recording import Recording

    nj = int(model.n_joints)
    types = tuple(getattr(model, "joint_types", ()) or ("revolute",) * nj)
    units = ["N" if k == "prismatic" else "N*m" for k in types]
    names = [f"tau{j + 1}" for j in range(nj)]
    data = tau_hat
    if tau_measured is not None:
        names += [f"tau{j + 1}_measured" for j in range(nj)]
        data = np.concatenate([tau_hat, tau_measured], axis=1)
        units = units + units
    return Recording(t, data, names, units=units, metadata=metadata or {})


# ---------------------------------------------------------------------- units
_STANDARD_UNITS = {
    "m": "kg",
    "mcx": "kg*m",
    "mcy": "kg*m",
    "mcz": "kg*m",
    "XX": "kg*m**2",
    "XY": "kg*m**2",
    "XZ": "kg*m**2",
    "YY": "kg*m**2",
    "YZ": "kg*m**2",
    "ZZ": "kg*m**2",
    "Ia": "kg*m**2",
    "Fv": "N*m*s/rad",
    "Fvp": "N*m*s/rad",
    "Fvn": "N*m*s/rad",
    "Fc": "N*m",
    "Fcp": "N*m",
    "Fcn": "N*m",
    "OF": "N*m",
}
_PRISMATIC_UNITS = {"Ia": "kg", "Fv": "N*s/m", "Fvp": "N*s/m", "Fvn": "N*s/m"}
_PRISMATIC_UNITS.update({k: "N" for k in ("Fc", "Fcp", "Fcn", "OF")})


def _unit_of(name: str, model) -> str:
    """Unit of a regressor column: standard-parameter prefix, or a monomial of model units."""
    match = re.fullmatch(r"([A-Za-z]+?)(\d+)", name)
    if match and match[1] in _STANDARD_UNITS:
        prefix, j = match[1], int(match[2])
        types = getattr(model, "joint_types", None)
        if types is not None and j - 1 < len(types) and types[j - 1] == "prismatic":
            return _PRISMATIC_UNITS.get(prefix, _STANDARD_UNITS[prefix])
        return _STANDARD_UNITS[prefix]
    units = getattr(model, "units", {}) or {}
    parts = []
    for factor in name.split("*"):
        if not factor:
            continue
        if factor in units and units[factor]:
            parts.append(units[factor])
        elif re.fullmatch(r"\d+", factor) and parts:
            parts[-1] = f"{parts[-1]}**{factor}"
    text = "*".join(parts).replace("**2*", "**2*")
    return text


def _joint_of(name: str) -> int | None:
    match = re.search(r"(\d+)(?:\*\*\d+)?R?$", name)
    return int(match[1]) if match else None


# ---------------------------------------------------------------------- estimator
def _gains_from(value, name: str, n: int, metadata: Mapping[str, Any]) -> np.ndarray | None:
    if value is None:
        value = metadata.get(name)
    if value is None:
        return None
    return per_joint(value, name, n)


class IDIMEstimator(EstimatorMixin):
    """Inverse-dynamic-model identification of the base parameters: OLS, WLS or IV.

    Settings follow scikit-learn's protocol (`EstimatorMixin`: ``get_params``, ``set_params``,
    a ``repr`` of the settings that differ from the defaults, ``fit_arrays``).

    Parameters
    ----------
    model : ChainModel
        Linear in its base parameters (``regressor``, ``base_parameters()``).
    method : {"ols", "wls", "iv"}
        Ordinary least squares; Gautier's two-step weighted least squares (rows of joint j
        weighted by ``1/σ̂_j`` from the OLS residual); or Janot–Gautier instrumental variables
        (instruments from a simulated closed loop of the current estimate, weighted like WLS).
    differentiation : {"physid", "butterworth"}
        State filter (see `idim_rows`).
    cutoff : float [rad/sample] or "auto"
        State-filter cut-off.
    half_width : int, optional
        FIR half-width M of the physid filter.
    decimate : int or "auto"
        Parallel-filter decimation factor nd.
    stderr : {"filtered", "hac", "iid"}
        ``"filtered"`` (default): white torque noise per joint passed through the known parallel
        filter and decimation, so the decimated residual's correlation ``ρ_l`` is the filter's
        own (lag 1 ≈ 0.18) and the sandwich uses it instead of estimating it: 94.3 / 93.5 /
        93.5 % coverage (OLS / WLS / IV) of 400 trials on planar2, where the HAC of ~64 rows
        gives 85–86 % (`benchmarks/bench_idim.py --part c`), and 98.6–100 % on the demo's arm6.
        ``"hac"``: the Newey–West sandwich with an estimated correlation (for residuals coloured
        by model error, at the price of a downward bias on few rows); ``"iid"``: classical
        ``σ² (WᵀW)⁻¹``.
    per_joint_variance : bool
        With ``stderr="iid"``: one noise variance per joint instead of a pooled one.
    hac_lag : int, optional
        HAC bandwidth in decimated rows (default: from the residual's correlation length).
    kp, kd : array_like (n_joints,), optional
        PD gains of the closed loop (IV only; default: the recording's metadata ``kp``/``kd``).
    max_iter : int
        IV iterations at most.
    tol : float
        IV stops when the relative change of the estimate falls below this.
    consistent : bool
        Also compute a physically consistent estimate (`ConsistentEstimate`).
    check_condition : bool
        Warn (`ConditionWarning`) above a condition number of 1e3 and refuse above 1e8.
    stick_threshold : float
        Joints with Coulomb friction: drop the equations where the joint is at or near rest
        (filtered |q̇_j| below this fraction of its rms, widened by the parallel filter's
        reach), where the friction torque is unknown (stiction) and the filters smear the
        stick/slip switch (default 0.05; 0 keeps every equation). The message says how many
        were dropped; `IDIMRows.stuck` marks them.
    """

    def __init__(
        self,
        model,
        method: str = "ols",
        *,
        differentiation: str = "physid",
        cutoff: float | str = "auto",
        half_width: int | None = None,
        decimate: int | str = "auto",
        stderr: str = "filtered",
        per_joint_variance: bool = True,
        hac_lag: int | None = None,
        kp=None,
        kd=None,
        max_iter: int = 10,
        tol: float = 1e-4,
        consistent: bool = False,
        check_condition: bool = True,
        stick_threshold: float = 0.05,
    ):
        self.model = model
        self.method = method
        self.differentiation = differentiation
        self.cutoff = cutoff
        self.half_width = half_width
        self.decimate = decimate
        self.stderr = stderr
        self.per_joint_variance = per_joint_variance
        self.hac_lag = hac_lag
        self.kp = kp
        self.kd = kd
        self.max_iter = max_iter
        self.tol = tol
        self.consistent = consistent
        self.check_condition = check_condition
        self.stick_threshold = stick_threshold

    # checks ---------------------------------------------------------------------------
    def _check_settings(self) -> None:
        if self.method not in METHODS:
            raise InputError(f"method must be one of {METHODS}; got {self.method!r}.")
        if self.stderr not in ("hac", "iid", "filtered"):
            raise InputError(f"stderr must be 'hac', 'iid' or 'filtered'; got {self.stderr!r}.")
        check_int(self.max_iter, "max_iter", minimum=1)
        check_int(self.hac_lag, "hac_lag", minimum=0, allow_none=True)
        check_int(self.half_width, "half_width", minimum=1, allow_none=True)
        check_positive(self.tol, "tol")

    def _check_excitation(self, W: np.ndarray, info: BaseInfo, where: str) -> float:
        """Refuse unexcited columns and meaningless conditioning; warn on poor conditioning."""
        a = W.reshape(-1, W.shape[-1])
        norms = np.linalg.norm(a, axis=0)
        dead = np.flatnonzero(norms <= UNEXCITED_RTOL * max(norms.max(), 1e-300))
        if dead.size:
            text = []
            for k in dead:
                j = _joint_of(info.names[k])
                text.append(f"{info.names[k]}" + (f" (joint {j})" if j is not None else ""))
            raise IdentifiabilityError(
                f"nothing in {where} excites the base parameter(s) {', '.join(text)}: their "
                "regressor columns are zero (e.g. a joint that never moves, or never "
                "accelerates). Move those joints in the experiment (physid design-excitation), "
                "or fix those parameters in the model."
            )
        cond = condition_number(a)
        if cond > COND_REFUSE:
            scaled = a / norms
            _, r, perm = linalg.qr(scaled, mode="economic", pivoting=True)
            weakest = info.names[perm[-1]]
            raise IdentifiabilityError(
                f"the base regressor of {where} has condition number {cond:.3g} (limit "
                f"{COND_REFUSE:.0e}): the data cannot separate the base parameters (the weakest "
                f"is {weakest}); an estimate would be meaningless. Record a better exciting "
                "trajectory (physid design-excitation MODEL) or stack more experiments."
            )
        if self.check_condition and cond > COND_WARN:
            warnings.warn(
                f"the base regressor has condition number {cond:.3g} (column-scaled; above "
                f"{COND_WARN:.0e} the estimates of weakly excited parameters are poor). Design "
                "a better excitation with physid design-excitation MODEL (or "
                "physid.analysis.design_excitation).",
                ConditionWarning,
                stacklevel=3,
            )
        return cond

    # fit --------------------------------------------------------------------------------
    def fit(self, recording):
        """Identify the base parameters from one recording or a list of them.

        Parameters
        ----------
        recording : Recording or sequence of Recording
            ``t`` [s], ``q1..qn`` [rad], ``tau1..taun`` [N·m] (IV also ``r1..rn`` [rad] and
            the PD gains, in the metadata or as ``kp``/``kd``). Several recordings are filtered
            each on its own and stacked.

        Returns
        -------
        self
            With ``result_`` (`IDIMResult`), ``rows_`` (`IDIMRows`) and ``base_`` (`BaseInfo`).

        Raises
        ------
        IdentifiabilityError
            An unexcited base parameter, or a condition number above 1e8.
        InputError
            IV without a known controller; bad settings.
        SamplingError, ShapeError
            Recordings that differ in joints or sample period; decimation leaving fewer rows
            than parameters.
        """
        from ..signals.recording import Recording

        self._check_settings()
        recs = [recording] if isinstance(recording, Recording) else list(recording)
        model = self.model
        _check_all_unknown(model)
        nj = int(model.n_joints)
        info = base_regressor_info(model)
        p = info.n_base
        controller = None
        if self.method == "iv":
            controller = self._controller(recs, nj)
        rows = idim_rows(
            model,
            recs,
            info=info,
            differentiation=self.differentiation,
            cutoff=self.cutoff,
            half_width=self.half_width,
            decimate=self.decimate,
            stick_threshold=self.stick_threshold,
        )
        n_rows = rows.W.shape[0]
        if n_rows * nj <= p:
            raise SamplingError(
                f"after filtering and decimate={rows.decimate} only {n_rows} rows × {nj} joints "
                f"= {n_rows * nj} equations remain for {p} base parameters; use a smaller "
                "decimate, a longer recording, or more recordings."
            )
        notes: list[str] = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConditionWarning)
            cond = self._check_excitation(rows.W, info, "the recording(s)")
        for w in caught:
            notes.append(str(w.message))
            warnings.warn(w.message, w.category, stacklevel=2)

        W, y = rows.W, rows.tau
        history = []
        beta = _lstsq(W, y, np.ones(nj))
        history.append(beta)
        sigma = _joint_sigma(W, y, beta, p)
        weights = np.ones(nj)
        changes: list[float] = []
        iterations = 0
        Z = None
        if self.method in ("wls", "iv"):
            weights = 1.0 / np.where(sigma > 0, sigma, 1.0)
            beta = _lstsq(W, y, weights)
            history.append(beta)
            sigma = _joint_sigma(W, y, beta, p)
        if self.method == "iv":
            beta, Z, changes, theta = self._iv(
                recs, rows, info, controller, beta, weights, history, notes
            )
            iterations = len(changes)
            sigma = _joint_sigma(W, y, beta, p)
        e = y - W @ beta
        cov, lag, reason = self._covariance(
            W, e, weights, Z, rows.segments, sigma, p, decimate=rows.decimate
        )
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if reason is None else None

        tau_norm = np.linalg.norm(y, axis=0)
        rel = {"overall": float(np.linalg.norm(e) / max(np.linalg.norm(y), 1e-300))}
        for j in range(nj):
            rel[f"tau{j + 1}"] = float(np.linalg.norm(e[:, j]) / max(tau_norm[j], 1e-300))
        names = info.names
        params = dict(zip(names, beta.tolist(), strict=True))
        units = {n: _unit_of(c, model) for n, c in zip(names, info.independent, strict=True)}
        success = bool(np.all(np.isfinite(beta)))
        message = (
            f"IDIM-{self.method.upper()} on {len(recs)} recording(s), {n_rows} rows; condition "
            f"number {cond:.3g}."
        )
        if rows.stuck is not None and rows.stuck.any():
            share = rows.stuck.mean(axis=0)
            worst_j = int(np.argmax(share))
            message += (
                f" {int(rows.stuck.sum())} of {rows.stuck.size} joint equations dropped near "
                f"rest (Coulomb joints at |q̇| < {self.stick_threshold:g}·rms, where stiction "
                f"makes the friction torque unknown; most on joint {worst_j + 1}, "
                f"{100 * share[worst_j]:.0f} %)."
            )
        worst = max((k for k in rel if k != "overall"), key=rel.get)
        if rel["overall"] > REL_ERROR_FAIL or rel[worst] > REL_ERROR_FAIL_JOINT:
            success = False
            message += (
                f" The model does not explain the torques: relative torque error "
                f"{rel['overall']:.3g} overall, {rel[worst]:.3g} on {worst} (a fit that explains "
                f"the data stays below {REL_ERROR_FAIL:g} overall and {REL_ERROR_FAIL_JOINT:g} per "
                "joint). Check the channel map (q and tau of each joint, their units and signs), "
                "do not remove the mean of q or tau (a torque-sensor offset is the model's OF "
                "term), and check that the model belongs to the arm."
            )
        if self.method == "iv" and changes and changes[-1] > self.tol:
            success = False
            message += (
                f" IV did not converge in {len(changes)} iterations (last relative change "
                f"{changes[-1]:.2g} > tol {self.tol:g}); raise max_iter, check the gains, or "
                "improve the excitation."
            )
        derived: dict[str, float] = {}
        consistent = None
        if self.consistent:
            from .consistent import consistent_estimate

            consistent = consistent_estimate(model, info, W, y, beta, weights)
            if not consistent.converged:
                success = False
                message += " " + consistent.message
                notes.append(consistent.message)
            derived = dict(consistent.standard)
            units.update({n: _unit_of(n, model) for n in derived})
        self.result_ = IDIMResult(
            stick_threshold=float(self.stick_threshold),
            names=names,
            parameters=params,
            expressions=dict(zip(names, info.expressions, strict=True)),
            columns=info.independent,
            stderr=None if sd is None else dict(zip(names, sd.tolist(), strict=True)),
            stderr_reason=reason,
            stderr_method=self.stderr,
            covariance=cov,
            derived=derived,
            units=units,
            method=f"idim-{self.method}",
            success=success,
            message=message,
            condition_number=float(condition_number(W * weights[None, :, None])),
            relative_error=rel,
            joint_sigma={f"tau{j + 1}": float(s) for j, s in enumerate(sigma)},
            n_rows=int(n_rows),
            n_recordings=len(recs),
            cutoff=rows.cutoff,
            half_width=rows.half_width,
            decimate=rows.decimate,
            dt=rows.dt,
            differentiation=self.differentiation,
            hac_lag=int(lag),
            iterations=iterations,
            iv_changes=tuple(changes),
            consistent=consistent,
            warnings=tuple(notes),
            history=np.array(history),
            t=rows.t,
            residuals=e,
            model=model,
        )
        self.rows_ = rows
        self.base_ = info
        return self

    # pieces ------------------------------------------------------------------------------
    def _covariance(self, W, e, weights, Z, segments, sigma, p, decimate=1):
        """Covariance of the estimate: HAC sandwich, classical (per-joint variance), or classical
        with the correlation the parallel filter gives white noise (``stderr="filtered"``)."""
        n, nj = e.shape
        Ww = W * weights[None, :, None]
        ew = e * weights[None, :]
        A_rows = Ww if Z is None else Z * weights[None, :, None]
        A = A_rows.reshape(-1, p).T @ Ww.reshape(-1, p)  # ZᵀW (WᵀW for LS), weighted
        try:
            A_inv = np.linalg.solve(A, np.eye(p))
        except np.linalg.LinAlgError:
            return np.full((p, p), np.nan), 0, "the normal equations are singular"
        dof = n * nj / max(n * nj - p, 1)
        if self.stderr == "hac":
            lag = self.hac_lag
            if lag is None:
                lag = max(_newey_west_lag(n), 3 * _correlation_length(ew, segments))
                lag = int(min(lag, max(n // 4, 1)))
            scores = np.einsum("tjp,tj->tp", A_rows, ew)  # g_t = Σ_j Z_tj e_tj
            cov = dof * hac_covariance(scores, A_inv, segments, lag)
            return cov, lag, None
        # iid: Cov = A⁻¹ (Σ_j Z_jᵀ Σ_jj W_j... ) A⁻ᵀ with the weighted residual variance
        if self.per_joint_variance:
            var = np.sum(ew**2, axis=0) / max(n - p / nj, 1.0)
        else:
            var = np.full(nj, np.sum(ew**2) / max(n * nj - p, 1))
        Zs = A_rows * np.sqrt(var)[None, :, None]
        meat = Zs.reshape(-1, p).T @ Zs.reshape(-1, p)
        if self.stderr == "filtered":  # Σ_j = σ_j² R, R_kl = ρ(|k − l|) within a recording
            rho = _decimated_noise_correlation(int(decimate))
            for ell in range(1, min(rho.size, n)):
                same = (segments[ell:] == segments[:-ell])[:, None, None]
                G = np.einsum("tjp,tjq->pq", Zs[ell:] * same, Zs[:-ell])
                meat += rho[ell] * (G + G.T)
            return A_inv @ meat @ A_inv.T, rho.size - 1, None
        return A_inv @ meat @ A_inv.T, 0, None

    def _controller(self, recs, nj):
        """PD gains and references for IV; refuse when the controller is unknown."""
        out = []
        for k, rec in enumerate(recs):
            meta = dict(rec.metadata)
            kp = _gains_from(self.kp, "kp", nj, meta)
            kd = _gains_from(self.kd, "kd", nj, meta)
            refs = [f"r{j + 1}" for j in range(nj)]
            missing = [c for c in refs if c not in rec.names]
            if kp is None or kd is None or missing:
                what = []
                if kp is None:
                    what.append(f"the proportional gains ({arg('kp', '[...]', cli='LIST')})")
                if kd is None:
                    what.append(f"the derivative gains ({arg('kd', '[...]', cli='LIST')})")
                if missing:
                    what.append(f"the reference channels {missing}")
                raise InputError(
                    f"IDIM-IV simulates the closed loop, so it needs the controller; recording "
                    f"{k + 1} lacks {' and '.join(what)}. Give {arg('kp', '[...]', cli='LIST')} "
                    f"and {arg('kd', '[...]', cli='LIST')} and a recording with r1..rn, or use "
                    f"{arg('method', repr('ols'), cli='idim-ols')}/"
                    f"{arg('method', repr('wls'), cli='idim-wls')}."
                )
            out.append((kp, kd, rec.select(refs)))
        return out

    @staticmethod
    def _simulate(simulate, model, kp, kd, ref, t, q_meas, theta, theta_nominal, notes):
        """The closed loop of the current estimate; shrunk towards the nominal model if needed.

        A poor estimate can have a mass matrix that is not positive definite somewhere on the
        trajectory (the simulation then fails); the instruments only need to be correlated
        with the regressor, so the parameters are moved towards the model's nominal values
        (θ = θ_nom + α (θ̂ − θ_nom), α = 1, ½, ¼, 0) until the loop can be simulated.
        """
        from ..errors import SimulationError

        q0 = ref[0] if np.allclose(q_meas[0], ref[0], atol=1e-2) else q_meas[0]
        for alpha in (1.0, 0.5, 0.25, 0.0):
            params = theta_nominal + alpha * (theta - theta_nominal)
            try:
                sim = simulate(
                    model,
                    kp=kp,
                    kd=kd,
                    reference=ref,
                    t=t,
                    q0=q0,
                    params=params,
                    rtol=IV_RTOL,
                    atol=IV_ATOL,
                )
            except SimulationError:
                continue
            if alpha < 1.0:
                notes.append(
                    f"IDIM-IV: the closed loop of the current estimate could not be simulated "
                    f"(mass matrix not positive definite or unstable); the instruments used "
                    f"{alpha:g}× the way from the nominal parameters to it."
                )
            return sim, params
        raise SimulationError(
            "IDIM-IV could not simulate the closed loop even with the model's nominal "
            "parameters; check the gains (kp=, kd=) and the references r1..rn."
        )

    def _iv(self, recs, rows, info, controller, beta, weights, history, notes):
        """Janot–Gautier iterations: simulate, build instruments, solve ZᵀW β = Zᵀτ."""
        from ..simulate.closed_loop import simulate_closed_loop

        model = self.model
        nj = int(model.n_joints)
        theta = np.asarray(model.parameter_vector(None), dtype=float)
        theta_nominal = theta.copy()
        changes: list[float] = []
        instruments: list[np.ndarray] = []
        Z = None
        for _ in range(int(self.max_iter)):
            theta = _params_for_base(model, info, beta, theta)
            reached = info.from_standard(model.beta(theta))
            miss = float(np.max(np.abs(reached - beta) / np.maximum(np.abs(beta), 1e-9)))
            if miss > 1e-3 and not any(n.startswith("IDIM-IV: the model of") for n in notes):
                notes.append(
                    "IDIM-IV: the model of the simulated closed loop reaches the current base "
                    f"estimate only to a relative {miss:.2g} (it would need a negative mass, "
                    "inertia, armature or friction); the instruments come from that model."
                )
            Zs = []
            for k, rec in enumerate(recs):
                kp, kd, ref = controller[k]
                t = np.asarray(rec.t, dtype=float)
                q_meas = rec.select([f"q{j + 1}" for j in range(nj)])
                sim, used = self._simulate(
                    simulate_closed_loop,
                    model,
                    kp,
                    kd,
                    ref,
                    t,
                    q_meas,
                    theta,
                    theta_nominal,
                    notes,
                )
                # Janot–Gautier: the simulated (noise-free) q goes through the *same* state
                # filter, regressor, parallel filter and decimation as the measured q, so that
                # Z carries the same filter distortion as W and differs from it by the noise only
                qs = sim.select([f"q{j + 1}" for j in range(nj)])
                _, qf, qdf, qddf, _ = _states(
                    qs, rec.dt, self.differentiation, rows.cutoff, rows.half_width
                )
                Zk, _ = parallel_decimate(
                    _base_regressor(model, info, qf, qdf, qddf), rows.decimate
                )
                if Zk.shape[0] != int(np.sum(rows.segments == k)):  # guard
                    raise ShapeError("internal: instrument rows do not match the regressor rows")
                Zs.append(Zk)
            Z = np.concatenate(Zs)
            new = _iv_solve(Z, rows.W, rows.tau, weights)
            change = float(
                np.linalg.norm(
                    (new - beta) / np.maximum(np.abs(new), 1e-12 + 1e-3 * np.abs(new).max())
                )
                / math.sqrt(new.size)
            )
            beta = new
            history.append(beta)
            instruments.append(Z)
            changes.append(change)
            if change < self.tol:
                break
            if len(changes) >= 3 and changes[-1] > changes[-2] > changes[-3]:
                # diverging: the simulated loop of a poor estimate gives poor instruments
                best = int(np.argmin(changes))
                beta = history[len(history) - len(changes) + best]
                Z = instruments[best]
                notes.append(
                    "IDIM-IV diverged (relative change per iteration "
                    + ", ".join(f"{c:.2g}" for c in changes)
                    + f"); kept iteration {best + 1}. The starting estimate is too poor for the "
                    "simulated loop: improve the excitation or lower the state-filter cutoff."
                )
                break
        return beta, Z, changes, theta


def _check_all_unknown(model) -> None:
    """Refuse a model that marks parameters as known: IDIM cannot hold them (review F6).

    IDIM estimates every base parameter, i.e. combinations of all standard parameters; a value
    marked known (``identify = false`` in a model file, a sidecar's ``identify = [...]``) would
    be estimated anyway, so the fit refuses instead of ignoring the mark.
    """
    names = tuple(getattr(model, "parameter_names", ()))
    unknown = getattr(model, "unknown", None)
    if unknown is None:
        return
    known = [n for n in names if n not in set(unknown)]
    if known:
        shown = ", ".join(known[:8]) + (f", … ({len(known)} in all)" if len(known) > 8 else "")
        raise InputError(
            f"model {getattr(model, 'name', '')!r} marks {shown} as known (identify = false in "
            "its model file, or a sidecar's identify = [...] list: model.unknown), but IDIM "
            "estimates every base parameter, combinations of all of them, and cannot hold "
            "some at given values. Remove the marks to estimate them all, or use "
            f"{arg('method', repr('input-error'), cli='input-error')}, which holds the known "
            "ones."
        )


def _lstsq(W, y, weights) -> np.ndarray:
    """argmin Σ_j w_j² ‖W_j β − y_j‖² by a column-scaled QR (numpy lstsq)."""
    p = W.shape[-1]
    a = (W * weights[None, :, None]).reshape(-1, p)
    b = (y * weights[None, :]).ravel()
    norms = np.linalg.norm(a, axis=0)
    d = 1.0 / np.where(norms > 0, norms, 1.0)
    x, *_ = np.linalg.lstsq(a * d, b, rcond=None)
    return x * d


def _iv_solve(Z, W, y, weights) -> np.ndarray:
    """β = (Zᵀ Ω W)⁻¹ Zᵀ Ω τ with the per-joint weights Ω = diag(w_j²), column-scaled."""
    p = W.shape[-1]
    z = (Z * weights[None, :, None]).reshape(-1, p)
    a = (W * weights[None, :, None]).reshape(-1, p)
    b = (y * weights[None, :]).ravel()
    norms = np.linalg.norm(a, axis=0)
    d = 1.0 / np.where(norms > 0, norms, 1.0)
    zn = np.linalg.norm(z, axis=0)
    dz = 1.0 / np.where(zn > 0, zn, 1.0)
    A = (z * dz).T @ (a * d)
    x = np.linalg.solve(A, (z * dz).T @ b)
    return x * d


def _joint_sigma(W, y, beta, p) -> np.ndarray:
    """Residual std per joint, σ̂_j² = ‖ρ_j‖² / (r − p/n_joints) (Gautier's two-step weights)."""
    e = y - W @ beta
    n, nj = e.shape
    kept = np.sum(np.any(W != 0.0, axis=2), axis=0)  # equations not dropped (stick_threshold)
    return np.sqrt(np.sum(e**2, axis=0) / np.maximum(kept - p / nj, 1.0))


#: Standard parameters without a sign constraint (first moments, products of inertia, offsets).
_SIGNED = re.compile(r"(mc[xyz]|XY|XZ|YZ|OF)\d+")


def _params_for_base(model, info: BaseInfo, beta_base, theta0) -> np.ndarray:
    """Model parameters θ whose base parameters K β(θ) match ``beta_base`` (closest to θ0).

    For a model linear in its parameters this is ``θ0 + K⁺ (β̂ − K β(θ0))`` (one Gauss–Newton
    step is exact); otherwise a few `scipy.optimize.least_squares` iterations with a small pull
    towards θ0 along directions the base parameters leave free. Only parameters that cannot
    change sign keep it (a positive mass, diagonal inertia, armature, friction or length stays
    positive); first moments ``mc*``, products of inertia ``XY/XZ/YZ`` and offsets ``OF`` are
    free, so a base parameter that must change sign is reached exactly.
    """
    from scipy import optimize

    names = tuple(model.parameter_names)
    K = info.matrix
    target = np.asarray(beta_base, dtype=float)
    scale_b = np.maximum(np.abs(target), 1e-6 * max(np.abs(target).max(), 1e-12))
    theta0 = np.asarray(theta0, dtype=float)
    scale_t = np.where(theta0 != 0, np.abs(theta0), 1.0)

    def beta_of(th):
        return np.asarray(model.beta(dict(zip(names, th.tolist(), strict=True))), dtype=float)

    def fun(th):
        return np.concatenate(
            [(K @ beta_of(th) - target) / scale_b, 1e-4 * (th - theta0) / scale_t]
        )

    def jac(th):
        db = np.asarray(model.beta_jacobian(dict(zip(names, th.tolist(), strict=True))), float)
        return np.vstack([(K @ db) / scale_b[:, None], 1e-4 * np.diag(1.0 / scale_t)])

    signed = np.array([bool(_SIGNED.fullmatch(n)) for n in names], dtype=bool)
    positive = (theta0 > 0) & ~signed
    lower = np.where(positive, 1e-6 * theta0, -np.inf)
    sol = optimize.least_squares(
        fun, theta0, jac=jac, bounds=(lower, np.full(theta0.size, np.inf)), x_scale=scale_t
    )
    return sol.x


def _make(method: str):
    def factory(model, **settings):
        if isinstance(model, str):
            from ..models import load_model

            model = load_model(model)
        return IDIMEstimator(model, method, **settings)

    factory.__name__ = f"IDIMEstimator[{method}]"
    return factory


def _register() -> None:
    try:
        from .registry import register
    except ImportError:  # the registry lands separately
        return
    for m in METHODS:
        try:
            register(f"idim-{m}", _make(m), kind="chain")
        except InputError:
            pass


_register()
