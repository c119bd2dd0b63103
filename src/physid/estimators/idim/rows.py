"""IDIM stages 1-4 for one or more recordings: the filtered, decimated regression ``τ = W β``.

`idim_rows` runs, one recording at a time (several recordings are stacked *after* it, so that no
filter ever runs across the seam between two experiments)::

    q  ──► q^f, q̇^f, q̈^f                 (`.filtering.states`)
       ──► W = Y(q^f, q̇^f, q̈^f)[:, :, independent]      (`.base_parameters.base_regressor`)
    [W | τ] ──► low-pass along time, keep one sample in nd   (`.decimation.parallel_decimate`)
       ──► equations of stuck Coulomb joints zeroed         (`physid.estimators._stiction`)

and returns them as `IDIMRows`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..._hints import joint_hint
from ..._validate import check_int, sample_period
from ...errors import InputError, SamplingError, ShapeError, arg
from .._stiction import (
    STICK_AUTO,
    check_stick_threshold,
    coarse_speed_rms,
    contamination_reach,
    coulomb_joints,
    dilate,
    drop_equations,
    reversal_samples,
    sticking_samples,
    stuck_samples,
)
from .base_parameters import BaseInfo, base_regressor, base_regressor_info, write_in_place
from .choose import cross_validated_error, decimate_candidates, pick
from .decimation import decimation_edge, parallel_decimate
from .filtering import (
    DIFFERENTIATIONS,
    auto_cutoff,
    default_half_width,
    state_filter_drop,
    states,
)

__all__ = ["IDIMRows", "idim_rows"]


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
    reversal : ndarray of bool, shape (n_rows, n_joints), or None
        With ``stick_threshold="auto"``: the equations near a reversal of a joint with dry
        friction (kept; `IDIMEstimator` drops them when the residual shows the friction step
        there, `physid.estimators._stiction.elevated_joints`).
    choice : str
        With ``decimate="auto"``: how nd was chosen (the candidates' cross-validated errors).
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
    reversal: np.ndarray | None = None
    choice: str = ""


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
            f"tau1..tau{n_joints} [N·m] (it has {names}). "
            + joint_hint(n_joints, names, dict(zip(recording.names, recording.units, strict=True)))
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


def _as_recordings(recordings) -> list:
    """One Recording or a sequence of them, as a non-empty list."""
    from ...signals.recording import Recording

    if isinstance(recordings, Recording):
        recordings = [recordings]
    recordings = list(recordings)
    if not recordings:
        raise InputError("recordings must hold at least one Recording; got none.")
    return recordings


def _check_stackable(recordings, arrays) -> list[float]:
    """The sample period of each recording; refuse recordings that cannot be stacked."""
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
    return dts


def _resolve_cutoff(cutoff, q_first) -> float:
    """The state-filter cut-off [rad/sample]: given, or `auto_cutoff` on the first recording."""
    if isinstance(cutoff, str):
        if cutoff != "auto":
            raise InputError(
                f"{arg('cutoff')} must be a number [rad/sample] or 'auto'; got {cutoff!r}."
            )
        cutoff = auto_cutoff(q_first)
    try:
        cutoff = float(cutoff)
    except (TypeError, ValueError):
        cutoff = float("nan")
    if not 0.0 < cutoff <= np.pi:
        raise InputError(f"{arg('cutoff')} must lie in (0, π] rad/sample; got {cutoff!r}.")
    return cutoff


def _resolve_decimate(decimate, cutoff: float, n_shortest: int, n_base: int, nj: int) -> int:
    """nd: given, or "auto" (``floor(1.6 π / cutoff)``, lowered to keep enough equations)."""
    if isinstance(decimate, str):
        if decimate != "auto":
            raise InputError(
                f"{arg('decimate')} must be a positive integer or 'auto'; got {decimate!r}."
            )
        decimate = max(1, int(math.floor(1.6 * np.pi / cutoff)))
        n_min = 0.75 * n_shortest  # after the state filter
        rows_needed = max(20.0 * n_base / nj, 50.0)
        decimate = max(1, min(decimate, int(n_min / (rows_needed + 24.0))))
    return check_int(decimate, "decimate", minimum=1)


def _full_rate(model, info, k, q, tau, dt, filters, nds):
    """One recording's state filter and base regressor at every sample: ``(idx, stacked,
    qdf, m_used)``, ``stacked`` = [W | τ] (n, n_joints·p + n_joints)."""
    idx, qf, qdf, qddf, m_used = states(q, dt, *filters)
    nj, p = qf.shape[1], info.n_base
    stacked = np.empty((qf.shape[0], nj * p + nj))  # [W | τ], W written in place
    write_in_place(
        stacked[:, : nj * p],
        nj,
        p,
        lambda out: base_regressor(model, info.columns, qf, qdf, qddf, out=out),
    )
    stacked[:, nj * p :] = tau[idx]
    nd = max(nds)
    if stacked.shape[0] <= 2 * decimation_edge(nd) + 1:
        raise SamplingError(
            f"recording {k + 1}: after the state filter (half-width {m_used} samples at each "
            f"end) {stacked.shape[0]} samples remain, too few for decimate={nd} (the parallel "
            f"filter drops {decimation_edge(nd)} at each end); use a smaller decimate, a higher "
            "cutoff or a longer recording."
        )
    return idx, stacked, qdf, m_used


def _at_rest(q, dt, stick):
    """What the ``"auto"`` stiction rule reads from one recording's measured positions, once
    for every candidate nd: ``(sticking samples, rms speed per joint)``, or None."""
    if stick is None or stick[1] != STICK_AUTO:
        return None
    return sticking_samples(q, dt, stick[0]), coarse_speed_rms(q, dt)


def _recording_rows(full, at_rest, nd, stick, cutoff, nj, p):
    """One recording's rows at decimation ``nd``: parallel filter, stuck equations.

    ``full`` is `_full_rate`'s output; ``at_rest`` `_at_rest`'s; ``stick`` is
    ``(coulomb, threshold)`` or None. Returns
    ``(W_k, tau_k, samples, stuck, reversal)``: the decimated rows, the samples of the
    recording they belong to, the stuck and reversal masks (or None).
    """
    idx, stacked, qdf, _ = full
    dec, kept = parallel_decimate(stacked, nd)
    Wk = dec[:, : nj * p].reshape(-1, nj, p)
    tauk = dec[:, nj * p :]
    stuck = reversal = None
    if stick is not None:
        coulomb, rule = stick
        if rule == STICK_AUTO:  # sticking shown by the measured positions, on every sample
            reach = contamination_reach(cutoff, nd)
            still, speed = at_rest
            stuck = dilate(still, reach)[idx[kept]]
            reversal = reversal_samples(qdf, coulomb, reach, speed)[kept] & ~stuck
        else:
            stuck = stuck_samples(qdf, coulomb, rule, decimation_edge(nd))[kept]
        drop_equations(Wk, tauk, stuck)  # joint j's equation at that row: no weight
    return Wk, tauk, idx[kept], stuck, reversal


def _stack(parts):
    """Concatenate the per-recording parts ``(W, tau, samples, stuck, reversal, target)``."""
    Ws, taus, samples, stucks, revs, targets = zip(*parts, strict=True)
    segs = [np.full(s.size, k) for k, s in enumerate(samples)]
    return (
        np.concatenate(Ws),
        np.concatenate(taus),
        np.concatenate(samples),
        np.concatenate(segs),
        None if stucks[0] is None else np.concatenate(stucks),
        None if revs[0] is None else np.concatenate(revs),
        None if targets[0] is None else np.concatenate(targets),
    )


def _all_rows(model, info, arrays, dts, filters, nds, stick):
    """The rows of every recording for each candidate nd; the chosen nd and why.

    With one candidate, its rows. With several (``decimate="auto"``), the rows of each, scored
    by `physid.estimators.idim.choose.cross_validated_error`; the recordings' full-rate
    regressors are computed once and dropped after their candidates are decimated.
    """
    nj, p = arrays[0][1].shape[1], info.n_base
    per_nd: dict[int, list] = {nd: [] for nd in nds}
    m_used = 0
    for k, (_, q, tau) in enumerate(arrays):
        full = _full_rate(model, info, k, q, tau, dts[k], filters, nds)
        m_used = full[3]
        target = None
        at_rest = _at_rest(q, dts[k], stick)
        for nd in nds:
            Wk, tauk, samples, stuck, rev = _recording_rows(
                full, at_rest, nd, stick, filters[1], nj, p
            )
            per_nd[nd].append((Wk, tauk, samples, stuck, rev, target))
        del full
    stacked = {nd: _stack(parts) for nd, parts in per_nd.items()}
    if len(nds) == 1:
        return nds[0], stacked[nds[0]], m_used, ""
    lengths = [a[0].size for a in arrays]
    common = stacked[max(nds)]  # judged in the most smoothed band (`choose`'s docstring)
    ev = (common[0], common[1], common[3], common[2])
    errors = [
        cross_validated_error((s[0], s[1], s[3], s[2]), ev, lengths) for s in stacked.values()
    ]
    nd, why = pick(list(nds), errors)
    return nd, stacked[nd], m_used, why


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
    stick_threshold: float | str = 0.0,
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
        nd; "auto": chosen by the data among ``floor(f π / cutoff)`` for f in 1.6 (the
        parallel filter's cut-off 0.8 π / nd at half the state filter's, where the FIR bank is
        flat), 0.8 and 3.2, 6.4, 12.8, 25.6 (octaves down to 1/32 of the state filter's
        cut-off), each lowered when fewer than 20 equations per base parameter would remain:
        the one with the lowest 5-fold cross-validated torque error, judged on the rows of the
        most smoothing candidate (`physid.estimators.idim.choose`; the first stays unless
        another is 2 % better). Without torques (``torque=False``) the first.
    torque : bool
        False: a recording may lack ``tau1..taun`` (for a prediction from the motion alone);
        ``tau`` of the rows is then zero.
    stick_threshold : "auto" or float
        Which equations of a joint with dry friction (``Fc{j}``, ``Fcp{j}``, ``Fcn{j}``) to
        drop. While a joint sticks the friction torque holding it lies anywhere in [−Fc, Fc],
        but the regressor writes Fc·sign(q̇) of a speed that is only noise; those equations are
        wrong, not noisy. ``"auto"`` (what `IDIMEstimator` uses): where the measured position
        stays within its noise for a sustained interval, widened by the filters' main lobes
        (`physid.estimators._stiction`); a number F in (0, 1): where the filtered speed is
        below F times its rms, widened by the parallel filter's length (earlier versions'
        rule); 0 (the default here) keeps every equation.

    Returns
    -------
    IDIMRows

    Raises
    ------
    ShapeError, SamplingError, InputError
        Recordings with other joints or sampling periods than the first one, too short for the
        filters, or bad settings.
    """
    recordings = _as_recordings(recordings)
    if differentiation not in DIFFERENTIATIONS:
        raise InputError(
            f"differentiation must be one of {DIFFERENTIATIONS}; got {differentiation!r}."
        )
    info = info or base_regressor_info(model)
    nj = int(model.n_joints)
    arrays = [_recording_arrays(r, nj, torque) for r in recordings]
    dts = _check_stackable(recordings, arrays)
    cutoff = _resolve_cutoff(cutoff, arrays[0][1])
    half_width = check_int(half_width, "half_width", minimum=1, allow_none=True)
    n_shortest = min(a[0].size for a in arrays)
    if half_width is None and differentiation == "physid":
        # one M for every recording (the instruments of IDIM-IV and `validate` reuse it)
        half_width = default_half_width(cutoff, n_shortest)
    if isinstance(decimate, str) and decimate == "auto" and torque:
        edge = state_filter_drop(differentiation, cutoff, half_width)
        nds = decimate_candidates(cutoff, n_shortest, info.n_base, nj, edge)
    else:
        nds = [_resolve_decimate(decimate, cutoff, n_shortest, info.n_base, nj)]
    stick_threshold = check_stick_threshold(stick_threshold)
    coulomb = coulomb_joints(model)
    drop = stick_threshold != 0 and bool(coulomb.any())
    stick = (coulomb, stick_threshold) if drop else None

    filters = (differentiation, cutoff, half_width)
    nd, rows, m_used, why = _all_rows(model, info, arrays, dts, filters, nds, stick)
    W, tau, samples, segs, stuck, reversal, _ = rows
    t = np.concatenate([arrays[k][0][samples[segs == k]] for k in range(len(arrays))])
    return IDIMRows(
        W=W,
        tau=tau,
        t=t,
        segments=segs,
        samples=samples,
        cutoff=cutoff,
        half_width=int(m_used),
        decimate=nd,
        dt=float(dts[0]),
        stuck=stuck if drop else None,
        reversal=reversal if drop and stick_threshold == STICK_AUTO else None,
        choice=why,
    )
