"""Streamed IDIM, the survey pass: what a streamed fit must know before its main pass.

`plan_streamed` reads each block source once (the q and tau channels, block by block) and returns
a `StreamPlan`: the sources' lengths and period, the state-filter cut-off (``"auto"``: the Welch
spectrum of the first source accumulated segment by segment exactly as
`physid.estimators.idim.filtering.auto_cutoff` computes it), the FIR half-width, the candidate
decimations, the robust noise statistics and the window margins of the main pass
(`physid.estimators.idim.stream_window`). The spectrum is taken of q minus the first block's
mean where `auto_cutoff` removes the record's (a linear detrend follows in every segment: the
difference is rounding).

Where the in-memory fit takes a whole-record median (the position and torque noise of
`physid.estimators._stiction.position_noise` and `torque_noise_floor`), the survey takes the
median of the estimates of blocks of ``max(block_samples, SURVEY_BLOCK)`` samples: identical for
records up to that length, a robust estimate of the same quantity beyond. Sums, extrema and the
quantum of a position grid are exact.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from ..._validate import check_int
from ...errors import InputError, SamplingError, ShapeError, arg
from ...signals.noise import third_difference_sigma
from .._stiction import (
    NOISE_BAND,
    STICK_AUTO,
    STILL_MIN_SAMPLES,
    STILL_SECONDS,
    check_stick_threshold,
    coarse_step,
    coulomb_joints,
    sticking_windows,
)
from .base_parameters import base_regressor_info
from .choose import decimate_candidates
from .filtering import (
    DIFFERENTIATIONS,
    butterworth_edge,
    default_half_width,
    state_filter_drop,
)
from .rows import _resolve_cutoff, _resolve_decimate
from .uncertainty import STDERR_METHODS

__all__ = ["StreamPlan", "plan_streamed", "survey_source", "plan_from_surveys", "SURVEY_BLOCK"]

#: Samples per block of the survey's robust statistics (medians): at least this many.
SURVEY_BLOCK = 1 << 16
#: Rows of the result's ``t``/``residuals`` at most (every k-th decimated row).
MAX_KEPT_ROWS = 20_000
#: An IIR filter's transient counts as gone where its impulse response is below this (relative).
DECAY = 1e-17


@dataclass(frozen=True, eq=False)
class SourceStats:
    """What the survey found in one source (all per joint, shape (n_joints,))."""

    n: int
    dt: float
    t0: float
    label: str
    pos_sigma: np.ndarray  # robust position noise [rad] (median of block estimates)
    quantum: np.ndarray  # position grid [rad] (0: none)
    q_scale: np.ndarray  # max |q| + 1 [rad]
    q_range: np.ndarray  # max q − min q [rad]
    mean_acc2: np.ndarray  # mean square coarse acceleration [rad²/s⁴]
    mean_vel2: np.ndarray  # mean square coarse speed [rad²/s²] (`coarse_speed_rms`)
    tau_sigma: np.ndarray  # robust torque noise [N·m]


@dataclass(frozen=True, eq=False)
class StreamPlan:
    """Settings and whole-record statistics of a streamed IDIM fit (picklable).

    Attributes
    ----------
    settings : dict
        The fit's settings as given (method, differentiation, stderr, …).
    n_joints, n_base : int
    cutoff : float [rad/sample]
    half_width : int
        FIR half-width M (physid) or the Butterworth edge [samples].
    candidates : tuple of int
        Decimations tried (one when ``decimate`` is given).
    sources : tuple of SourceStats
        Per source: length, period, noise statistics.
    coulomb : ndarray of bool, shape (n_joints,)
        Joints with dry friction.
    stick : "auto", float or None
        The stiction rule in force (None: every equation kept).
    qd_rms : ndarray, shape (n_sources, n_joints) or None
        The filtered speed's rms per source (the speed-fraction rule only).
    block_samples : int
        Samples read per block of the main pass.
    """

    settings: dict
    n_joints: int
    n_base: int
    cutoff: float
    half_width: int
    candidates: tuple
    sources: tuple
    coulomb: np.ndarray
    stick: object
    block_samples: int
    qd_rms: np.ndarray | None = None
    notes: tuple = field(default_factory=tuple)

    @property
    def lengths(self) -> list[int]:
        """Samples of each source."""
        return [s.n for s in self.sources]

    @property
    def dt(self) -> float:
        """The sources' sample period [s]."""
        return float(self.sources[0].dt)

    def offset(self) -> int:
        """Raw sample of the first full-rate (state-filtered) sample."""
        if self.settings["differentiation"] == "physid":
            return int(self.half_width)
        return 1 + int(self.half_width)

    def n_stacked(self, k: int) -> int:
        """Full-rate samples of source ``k`` after the state filter."""
        return int(self.sources[k].n) - 2 * self.offset()

    def n_rows(self, k: int, nd: int) -> int:
        """Decimated rows of source ``k`` at decimation ``nd``."""
        from .decimation import decimation_edge

        edge, n = decimation_edge(nd), self.n_stacked(k)
        return len(range(edge, n - edge, nd)) if nd > 1 else n

    def thinning(self, nd: int) -> int:
        """Keep every k-th decimated row for the result's residuals (at most `MAX_KEPT_ROWS`)."""
        total = sum(self.n_rows(k, nd) for k in range(len(self.sources)))
        return max(1, math.ceil(total / MAX_KEPT_ROWS))


def decay_length(sos, decay: float = DECAY) -> int:
    """Samples after which the impulse response of ``sos`` stays below ``decay`` of its peak.

    The transient a zero-phase filter leaves at a cut inside the record decays as fast, so
    a window with this margin on each side gives the whole record's values inside it.
    """
    n = 4096
    while True:
        x = np.zeros(n)
        x[0] = 1.0
        h = np.abs(signal.sosfilt(sos, x))
        last = int(np.flatnonzero(h > decay * h.max())[-1])
        if last < n - n // 4:
            return int(1.1 * last) + 8
        n *= 2


def _check_settings(method, differentiation, stderr, half_width, stick_threshold, block_samples):
    """Refuse settings the streamed fit cannot reproduce, in the caller's words."""
    if method == "iv":
        raise InputError(
            f"{arg('method', repr('iv'), cli='idim-iv')} cannot be streamed: each iteration "
            "re-simulates the closed loop over the whole record. Use "
            f"{arg('method', repr('ols'), cli='idim-ols')} or "
            f"{arg('method', repr('wls'), cli='idim-wls')} on the streamed record, or fit the "
            "record in memory."
        )
    if method not in ("ols", "wls"):
        raise InputError(f"{arg('method')} must be 'ols' or 'wls' when streamed; got {method!r}.")
    if stderr == "hac":
        raise InputError(
            f"{arg('stderr', repr('hac'), cli='hac')} needs the whole residual's correlation "
            f"length and cannot be streamed; use {arg('stderr', repr('filtered'), cli='filtered')}"
            " (the parallel filter's known correlation, the default) or "
            f"{arg('stderr', repr('iid'), cli='iid')}, or fit the record in memory."
        )
    if stderr not in STDERR_METHODS:
        raise InputError(f"{arg('stderr')} must be 'filtered' or 'iid'; got {stderr!r}.")
    if differentiation not in DIFFERENTIATIONS:
        raise InputError(
            f"{arg('differentiation')} must be one of {DIFFERENTIATIONS}; got {differentiation!r}."
        )
    check_int(half_width, "half_width", minimum=1, allow_none=True)
    check_int(block_samples, "block_samples", minimum=64)
    return check_stick_threshold(stick_threshold)


def _channels(source, nj: int, k: int) -> list[str]:
    """The q and tau channels of a source; refuse missing or extra joints."""
    names = list(source.names)
    want = [f"q{j + 1}" for j in range(nj)] + [f"tau{j + 1}" for j in range(nj)]
    missing = [c for c in want if c not in names]
    if missing:
        raise InputError(
            f"source {k + 1} ({_label(source, k)}) lacks channel(s) {missing}; IDIM needs "
            f"q1..q{nj} [rad] and tau1..tau{nj} [N·m] (it has {names})."
        )
    extra = [c for c in names if (m := re.fullmatch(r"(q|tau)(\d+)", c)) and int(m[2]) > nj]
    if extra:
        raise ShapeError(
            f"source {k + 1} ({_label(source, k)}) has channel(s) {extra} beyond the model's "
            f"{nj} joints; check that the record belongs to this model."
        )
    return want


def _label(source, k: int) -> str:
    meta = getattr(source, "metadata", None) or {}
    return str(getattr(source, "path", None) or meta.get("source") or f"source {k + 1}")


def _check_stackable(sources, stats) -> None:
    """Same joints and one period for every source (errors name the source)."""
    joints0 = sorted(c for c in sources[0].names if re.fullmatch(r"(q|tau)\d+", c))
    for k, (src, st) in enumerate(zip(sources, stats, strict=True)):
        if k == 0:
            continue
        if not math.isclose(st.dt, stats[0].dt, rel_tol=1e-6):
            raise SamplingError(
                f"source {k + 1} ({st.label}) has sample period {st.dt:.9g} s, source 1 has "
                f"{stats[0].dt:.9g} s; stacked records must share one period. Resample them "
                "to a common period first, or fit them one by one."
            )
        joints = sorted(c for c in src.names if re.fullmatch(r"(q|tau)\d+", c))
        if joints != joints0:
            raise ShapeError(
                f"source {k + 1} ({st.label}) has joint channels {joints}, source 1 has "
                f"{joints0}; stacked records must have the same joints."
            )


class _Welch:
    """`auto_cutoff`'s Welch spectrum, accumulated over consecutive samples (same segments)."""

    def __init__(self, n: int, offset):
        self.nperseg = int(min(n, 4096))
        self.step = self.nperseg - self.nperseg // 2  # scipy's default overlap: nperseg // 2
        self.offset = offset  # the first block's mean (the in-memory code removes the record's)
        self.buf = None
        self.total = None
        self.count = 0

    def add(self, q) -> None:
        x = q - self.offset
        self.buf = x if self.buf is None else np.concatenate([self.buf, x])
        nseg = (self.buf.shape[0] - self.nperseg) // self.step + 1
        if nseg < 1:
            return
        used = (nseg - 1) * self.step + self.nperseg
        f, p = signal.welch(
            self.buf[:used],
            window="blackmanharris",
            nperseg=self.nperseg,
            noverlap=self.nperseg - self.step,
            axis=0,
            detrend="linear",
        )
        self.f = f
        self.total = p * nseg if self.total is None else self.total + p * nseg
        self.count += nseg
        self.buf = self.buf[nseg * self.step :]

    def cutoff(self, ratio: float = 100.0, factor: float = 2.0) -> float:
        """The cut-off `auto_cutoff` gives [rad/sample]."""
        p = self.total / self.count
        omega = 2.0 * np.pi * self.f
        floor = np.median(p[omega > np.pi / 2], axis=0)
        edges = []
        for j in range(p.shape[1]):  # per joint
            above = np.flatnonzero(p[:, j] > ratio * max(floor[j], 1e-300))
            edges.append(omega[above[-1]] if above.size else omega[1])
        edge = max(max(edges), omega[1])
        return float(np.clip(factor * edge, 0.005, 0.6))


def _survey(source, k: int, nj: int, spectrum: bool, block: int):
    """One pass over a source: `SourceStats` and (``spectrum``) its `_Welch`."""
    chans = _channels(source, nj, k)
    n, dt = int(source.n_samples), float(source.dt)
    if not (np.isfinite(dt) and dt > 0) or n < 8:
        raise SamplingError(
            f"source {k + 1} ({_label(source, k)}) has {n} samples at period {dt!r} s; a "
            "streamed fit needs a uniformly sampled record of at least 8 samples."
        )
    h = coarse_step(n, dt)
    carry = None
    sig_q, sig_t, nonzero = [], [], [[] for _ in range(nj)]
    qmin, qmax, qabs = np.full(nj, np.inf), np.full(nj, -np.inf), np.zeros(nj)
    step_min, acc2, vel2 = np.full(nj, np.inf), np.zeros(nj), np.zeros(nj)
    welch = None
    for blk in source.blocks(block, chans):
        x = np.asarray(blk.select(chans), dtype=float)
        if not np.all(np.isfinite(x)):
            bad = int(np.flatnonzero(~np.all(np.isfinite(x), axis=1))[0])
            raise InputError(
                f"source {k + 1} ({_label(source, k)}) has a NaN or infinite value near sample "
                f"{bad} of a block starting at t = {float(blk.t[0]):.6g} s; split the record "
                "there or repair it."
            )
        if spectrum:
            welch = welch or _Welch(n, x[:, :nj].mean(axis=0))
            welch.add(x[:, :nj])
        qmin, qmax = np.minimum(qmin, x[:, :nj].min(0)), np.maximum(qmax, x[:, :nj].max(0))
        qabs = np.maximum(qabs, np.abs(x[:, :nj]).max(0))
        c = 0 if carry is None else carry.shape[0]
        y = x if carry is None else np.concatenate([carry, x])
        y3 = y[max(c - 3, 0) :]  # each difference once: the carry supplies the ones across cuts
        if y3.shape[0] >= 4:  # position_noise's and torque_noise_sigma's σ of the block
            sigma = third_difference_sigma(y3)
            sig_q.append(sigma[:nj])
            sig_t.append(sigma[nj:])
        d1 = np.abs(np.diff(y[max(c - 1, 0) :, :nj], axis=0))
        for j in range(nj):  # per joint: the grid test of position_noise on the first 2000 steps
            nz = d1[:, j][d1[:, j] > 0]
            if nz.size:
                step_min[j] = min(step_min[j], float(nz.min()))
                if sum(a.size for a in nonzero[j]) < 2000:
                    nonzero[j].append(nz[:2000])
        y2 = y[max(c - 2 * h, 0) :, :nj]
        if y2.shape[0] > 2 * h:
            acc = (y2[2 * h :] - 2.0 * y2[h:-h] + y2[: -2 * h]) / (h * dt) ** 2
            acc2 += np.sum(acc**2, axis=0)
            vel = (y2[2 * h :] - y2[: -2 * h]) / (2 * h * dt)
            vel2 += np.sum(vel * vel, axis=0)
        carry = y[-max(2 * h, 3) :]
    quantum = np.zeros(nj)
    for j in range(nj):  # per joint
        if np.isfinite(step_min[j]):
            ratio = np.concatenate(nonzero[j])[:2000] / step_min[j]
            if np.mean(np.abs(ratio - np.round(ratio)) < 1e-3) > 0.9:
                quantum[j] = step_min[j]
    stats = SourceStats(
        n=n,
        dt=dt,
        t0=float(source.t0),
        label=_label(source, k),
        pos_sigma=np.median(np.array(sig_q), axis=0),
        quantum=quantum,
        q_scale=qabs + 1.0,
        q_range=qmax - qmin,
        mean_acc2=acc2 / max(n - 2 * h, 1),
        mean_vel2=vel2 / max(n - 2 * h, 1),
        tau_sigma=np.median(np.array(sig_t), axis=0),
    )
    return stats, welch


def motionless(stats: SourceStats) -> np.ndarray:
    """`motionless_joints` of a surveyed source (bool per joint)."""
    if stats.n < 8:
        return np.zeros(stats.pos_sigma.size, dtype=bool)
    band = NOISE_BAND * stats.pos_sigma + 2.0 * stats.quantum + 1e-12 * stats.q_scale
    return stats.q_range <= band


def still_windows(stats: SourceStats):
    """``(band, widths)`` of the sticking rule for a surveyed source (`sticking_windows`)."""
    return sticking_windows(
        stats.pos_sigma, stats.quantum, stats.q_scale, stats.mean_acc2, stats.dt
    )


def plan_streamed(
    model,
    sources,
    *,
    method: str = "ols",
    differentiation: str = "physid",
    cutoff: float | str = "auto",
    half_width: int | None = None,
    decimate: int | str = "auto",
    stderr: str = "filtered",
    per_joint_variance: bool = True,
    stick_threshold: float | str = "auto",
    check_condition: bool = True,
    block_samples: int = 65536,
) -> StreamPlan:
    """The survey pass of a streamed IDIM fit: one read of each source's q and tau channels.

    Parameters
    ----------
    model : ChainModel
    sources : BlockSource, Recording, or a sequence of them
        Several sources are several experiments, stacked as `IDIMEstimator.fit` stacks a list.
    method, differentiation, cutoff, half_width, decimate, stderr, per_joint_variance,
    stick_threshold, check_condition
        As `IDIMEstimator` (``method`` "ols" or "wls"; ``stderr`` "filtered" or "iid").
    block_samples : int
        Samples read at a time in the main pass (the survey reads at least `SURVEY_BLOCK`).

    Returns
    -------
    StreamPlan

    Raises
    ------
    InputError
        IV, HAC, missing channels, NaN in a record, bad settings.
    SamplingError, ShapeError
        Sources with other periods or joints than the first; records too short.
    """
    from ...signals.blocks import as_block_source

    _check_settings(method, differentiation, stderr, half_width, stick_threshold, block_samples)
    srcs = _as_sources(sources, as_block_source)
    surveys = [
        survey_source(
            model, s, k, spectrum=k == 0 and cutoff == "auto", block_samples=block_samples
        )
        for k, s in enumerate(srcs)
    ]
    return plan_from_surveys(
        model,
        [tuple(s.names) for s in srcs],
        surveys,
        method=method,
        differentiation=differentiation,
        cutoff=cutoff,
        half_width=half_width,
        decimate=decimate,
        stderr=stderr,
        per_joint_variance=per_joint_variance,
        stick_threshold=stick_threshold,
        check_condition=check_condition,
        block_samples=block_samples,
    )


def survey_source(model, source, k: int, *, spectrum: bool, block_samples: int = 65536):
    """The survey of one source (a map step of a fit spread over many logs).

    Parameters
    ----------
    model : ChainModel
    source : BlockSource
    k : int
        The source's position among the fit's sources (0-based; for messages).
    spectrum : bool
        Also accumulate its Welch spectrum (the first source, for ``cutoff="auto"``).
    block_samples : int
        Samples read at a time (at least `SURVEY_BLOCK`).

    Returns
    -------
    tuple
        ``(SourceStats, welch or None)``, picklable: what `plan_from_surveys` combines.
    """
    block = max(int(block_samples), SURVEY_BLOCK)
    return _survey(source, k, int(model.n_joints), bool(spectrum), block)


def plan_from_surveys(
    model,
    names,
    surveys,
    *,
    method: str = "ols",
    differentiation: str = "physid",
    cutoff: float | str = "auto",
    half_width: int | None = None,
    decimate: int | str = "auto",
    stderr: str = "filtered",
    per_joint_variance: bool = True,
    stick_threshold: float | str = "auto",
    check_condition: bool = True,
    block_samples: int = 65536,
) -> StreamPlan:
    """The `StreamPlan` of sources already surveyed (the reduce step after `survey_source`).

    Parameters
    ----------
    model : ChainModel
    names : sequence of tuple of str
        Each source's channel names, in the sources' order.
    surveys : sequence
        `survey_source` of each source, in the same order (the first with its spectrum when
        ``cutoff="auto"``).
    method, differentiation, cutoff, half_width, decimate, stderr, per_joint_variance,
    stick_threshold, check_condition, block_samples
        As `plan_streamed`.

    Returns
    -------
    StreamPlan
    """
    stick = _check_settings(
        method, differentiation, stderr, half_width, stick_threshold, block_samples
    )
    nj = int(model.n_joints)
    info = base_regressor_info(model)
    stats = [s for s, _ in surveys]
    _check_stackable([_Named(n) for n in names], stats)
    if cutoff == "auto" and surveys[0][1] is None:
        raise InputError(
            "the first source's survey holds no spectrum, which cutoff='auto' needs: survey it "
            "with spectrum=True."
        )
    cut = _resolve_cutoff(surveys[0][1].cutoff() if cutoff == "auto" else cutoff, None)
    n_short = min(s.n for s in stats)
    if half_width is None and differentiation == "physid":
        half_width = default_half_width(cut, n_short)
    if differentiation == "physid":
        m = int(half_width)
    else:
        m = butterworth_edge(cut)
    if isinstance(decimate, str) and decimate == "auto":
        edge = state_filter_drop(differentiation, cut, half_width)
        nds = decimate_candidates(cut, n_short, info.n_base, nj, edge)
    else:
        nds = [_resolve_decimate(decimate, cut, n_short, info.n_base, nj)]
    coulomb = coulomb_joints(model)
    rule = stick if stick != 0 and bool(coulomb.any()) else None
    settings = {
        "method": method,
        "differentiation": differentiation,
        "stderr": stderr,
        "per_joint_variance": bool(per_joint_variance),
        "stick_threshold": stick,
        "check_condition": bool(check_condition),
    }
    plan = StreamPlan(
        settings,
        nj,
        info.n_base,
        cut,
        m,
        tuple(nds),
        tuple(stats),
        coulomb,
        rule,
        int(block_samples),
    )
    _check_lengths(plan)
    return plan


class _Named:
    """Only the channel names of a source (what `_check_stackable` reads)."""

    def __init__(self, names):
        self.names = tuple(names)


def _as_sources(sources, as_block_source) -> list:
    from ...signals.recording import Recording

    if isinstance(sources, Recording) or hasattr(sources, "blocks"):
        sources = [sources]
    srcs = [as_block_source(s) for s in list(sources)]
    if not srcs:
        raise InputError(f"{arg('sources')} must hold at least one record; got none.")
    return srcs


def _check_lengths(plan: StreamPlan) -> None:
    """The in-memory fit's refusals of records too short for the filters."""
    from .decimation import decimation_edge

    m = plan.half_width
    for k, st in enumerate(plan.sources):
        if plan.settings["differentiation"] == "physid" and st.n < 2 * m + 2:
            raise SamplingError(
                f"source {k + 1} ({st.label}) has {st.n} samples, fewer than the state filter "
                f"needs (2·half_width + 1 = {2 * m + 1}); use a longer record, a higher cutoff "
                "or a smaller half_width."
            )
        if plan.settings["differentiation"] == "butterworth" and st.n < 2 * m + 10:
            raise SamplingError(
                f"source {k + 1} ({st.label}) has {st.n} samples; the Butterworth state filter "
                f"at cutoff={plan.cutoff:.3g} rad/sample needs more than {2 * m + 10}."
            )
        nd = max(plan.candidates)
        if plan.n_stacked(k) <= 2 * decimation_edge(nd) + 1:
            raise SamplingError(
                f"source {k + 1} ({st.label}): after the state filter {plan.n_stacked(k)} "
                f"samples remain, too few for decimate={nd} (the parallel filter drops "
                f"{decimation_edge(nd)} at each end); use a smaller decimate, a higher cutoff "
                "or a longer record."
            )


_UNUSED = (STICK_AUTO, STILL_MIN_SAMPLES, STILL_SECONDS)
