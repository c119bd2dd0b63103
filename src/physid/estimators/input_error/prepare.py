"""Input-error, step 1: check the settings, filter the recording, plan the fit.

Part of `physid.estimators.input_error`. `filter_recording` gives the filtered signals
(`_Filtered`); `prepare` adds the filter-band check, the hold plan of unidentifiable
combinations, the start and the bounds (`_Problem`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..._hints import joint_hint
from ..._validate import check_int, check_length, check_positive, per_joint
from ...errors import DataFileError, IdentifiabilityError, InputError, ShapeError, arg
from ...filters import filter_derivatives
from ...filters.band import FilterBandCheck, FilterChoice, choose_filter, filter_band_check
from ...models.identifiability import (
    NumericIdentifiability,
    StructuralIdentifiability,
    hold_plan,
    numeric_identifiability,
    raise_if_not_excited,
    structural_identifiability,
)
from ..idim.predict import torque_recording
from .core import (
    DEFAULT_HALF_WIDTH,
    MIN_AUTO_HALF_WIDTH,
    NOISE_METHODS,
    STDERR_METHODS,
    FilterWarning,
)


# ---------------------------------------------------------------------- argument checks
def _gains(value, name: str, n_joints: int, metadata: Mapping[str, Any]) -> np.ndarray:
    """PD gains as an array (n_joints,), from the argument or the recording's metadata."""
    if value is None:
        for key in (name, name.capitalize(), name.upper()):
            if key in metadata:
                value = metadata[key]
                break
        else:
            gains = metadata.get("gains")
            if isinstance(gains, Mapping):
                value = gains.get(name, gains.get(name.capitalize()))
            if value is None:
                raise InputError(
                    f"{arg('torque', repr('pd'), cli='pd')} needs the {name} gains: pass "
                    f"{arg(name, '[...]', cli='a,b,...')} ({n_joints} values) or use a recording "
                    f"whose metadata holds '{name}'. Recording metadata keys: {sorted(metadata)}."
                )
    return per_joint(value, name, n_joints)


def _check_pd_only(metadata: Mapping[str, Any]) -> None:
    """Refuse ``torque="pd"`` on a log whose controller added a feed-forward to the PD law:
    the torque rebuilt from ``Kp (r - q) - Kd q̇`` would lack it (a silently wrong fit)."""
    ff = metadata.get("feedforward")
    if ff is not None and ff != "none":
        raise InputError(
            f"{arg('torque', repr('pd'), cli='pd')} rebuilds the torque from the PD law alone, "
            f"but this recording's controller added a feed-forward (metadata feedforward = "
            f"{ff!r}) that the rebuilt torque would lack. Use "
            f"{arg('torque', repr('measured'), cli='measured')} (the logged torques), or IDIM-IV, "
            "which simulates that controller."
        )


def _check_names(given: Mapping[str, float], names: Sequence[str], what: str) -> dict[str, float]:
    unknown = sorted(set(given) - set(names))
    if unknown:
        raise InputError(
            f"{arg(what)} names unknown parameter(s) {unknown}; the model's parameters are "
            f"{list(names)}."
        )
    out = {}
    for k, v in given.items():
        try:
            out[k] = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{what}: the value of {k!r} must be a number; got {v!r}.") from None
        if not math.isfinite(out[k]):
            raise InputError(f"{what}: the value of {k!r} must be finite; got {v!r}.")
    return out


def _fixed_spec(fixed, names: Sequence[str]) -> tuple[dict[str, float], tuple[str, ...]]:
    """``fixed=`` as (values given, names to hold at their starting values).

    A mapping ``{"l1": 0.4}`` holds l1 at 0.4; a list of names ``["l1"]`` holds each at its
    starting value (``initial=`` if given there, else the model's nominal value).
    """
    if fixed is None:
        return {}, ()
    if isinstance(fixed, Mapping):
        return _check_names(fixed, names, "fixed"), ()
    items = None
    if not isinstance(fixed, (str, bytes)) and isinstance(fixed, Iterable):
        items = list(fixed)
    if items is None or not all(isinstance(n, str) for n in items):
        raise InputError(
            f"{arg('fixed')} must be a mapping name -> value, e.g. "
            f"{arg('fixed', repr({'l1': 0.4}), cli='l1=0.4')}, or a list of parameter names held "
            f"at their starting values, e.g. fixed=['l1']; got {fixed!r} of type "
            f"{type(fixed).__name__}."
        )
    unknown = sorted(set(items) - set(names))
    if unknown:
        raise InputError(
            f"{arg('fixed')} names unknown parameter(s) {unknown}; the model's parameters are "
            f"{list(names)}."
        )
    return {}, tuple(dict.fromkeys(items))


def _initial_values(initial, names: Sequence[str]) -> dict[str, float]:
    """``initial=`` as a checked mapping name -> value (a mapping, or a result with parameters)."""
    if initial is None:
        return {}
    if not isinstance(initial, Mapping) and isinstance(
        getattr(initial, "parameters", None), Mapping
    ):
        shared = {k: v for k, v in initial.parameters.items() if k in names}
        if not shared:
            raise InputError(
                f"{arg('initial')} is a {type(initial).__name__} whose parameters "
                f"{sorted(initial.parameters)} share no name with the model's {list(names)}; "
                "pass a mapping name -> value instead (for base-parameter estimates use "
                f"{arg('start', repr('linear'), cli='linear')}, which maps them to the model's "
                "parameters)."
            )
        return _check_names(shared, names, "initial")
    if not isinstance(initial, Mapping):
        raise InputError(
            f"{arg('initial')} must be a mapping name -> value, e.g. "
            f"{arg('initial', repr({'m1': 50.1}), cli='m1=50.1')}; got {initial!r} of type "
            f"{type(initial).__name__}."
        )
    return _check_names(initial, names, "initial")


def _check_initial_vs_fixed(initial: Mapping[str, float], fixed: Mapping[str, float]) -> None:
    """Refuse a parameter given two different values, one to start from and one to hold."""
    clash = {n: (initial[n], fixed[n]) for n in initial if n in fixed and initial[n] != fixed[n]}
    if clash:
        text = ", ".join(f"{n}: initial {a:g}, fixed {b:g}" for n, (a, b) in clash.items())
        raise InputError(
            f"{arg('initial')} and {arg('fixed')} give different values for the same parameter "
            f"({text}); a fixed parameter is held at its fixed value, so its initial value would "
            "be ignored. Give it in only one of them."
        )


def _check_bounds(
    bounds: Mapping[str, Any], names: Sequence[str]
) -> dict[str, tuple[float, float]]:
    unknown = sorted(set(bounds) - set(names))
    if unknown:
        raise InputError(
            f"{arg('bounds')} names unknown parameter(s) {unknown}; the model's parameters are "
            f"{list(names)}."
        )
    out = {}
    for name, pair in bounds.items():
        try:
            lo, hi = (float(v) for v in pair)
        except (TypeError, ValueError):
            raise InputError(
                f"bounds[{name!r}] must be a pair (low, high); got {pair!r}."
            ) from None
        if not lo < hi:
            raise InputError(f"bounds[{name!r}] must have low < high; got {pair!r}.")
        out[name] = (lo, hi)
    return out


# ---------------------------------------------------------------------- what the steps share
@dataclass(frozen=True, eq=False)
class _Filtered:
    """A recording through the filters (`InputErrorEstimator._filter`)."""

    t: np.ndarray
    qf: np.ndarray
    qdf: np.ndarray
    qddf: np.ndarray
    tau_f: np.ndarray
    dt: float
    q: np.ndarray
    half_width: int
    cutoff: float
    choice: FilterChoice | None
    refilter: Any = None  # q_raw, tau_raw -> (q^f, q̇^f, q̈^f, τ^f) with the same filters
    tau: np.ndarray | None = None  # raw measured torques (torque="measured")


@dataclass(eq=False)
class _Problem:
    """What `InputErrorEstimator._prepare` sets up: filtered signals, plan, start and bounds.

    ``residual_matrix`` and ``jacobian`` evaluate the filtered equations of motion; rows of the
    Jacobian are ordered like ``e.ravel()`` (sample-major, joint-minor).
    """

    model: Any
    filtered: _Filtered
    advice: FilterChoice | None
    names: tuple[str, ...]
    t: np.ndarray
    qf: np.ndarray
    qdf: np.ndarray
    qddf: np.ndarray
    tau_f: np.ndarray
    dt: float
    band: FilterBandCheck
    structural: StructuralIdentifiability
    fixed: dict[str, float]
    free_idx: list[int]
    theta0: np.ndarray
    scale: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    notes: list[str]
    before: NumericIdentifiability | None = None
    # noise="compensate": the share of the residual energy the noise on q explains
    # (`.solve.noise_fraction`); None when no replicates were drawn
    noise_fraction: float | None = None

    @property
    def n_valid(self) -> int:
        return int(self.tau_f.shape[0])

    @property
    def free_names(self) -> tuple[str, ...]:
        return tuple(self.names[i] for i in self.free_idx)

    def full_theta(self, x: np.ndarray) -> np.ndarray:
        theta = self.theta0.copy()
        theta[self.free_idx] = x
        return theta

    def as_params(self, theta: np.ndarray) -> dict[str, float]:
        return dict(zip(self.names, theta.tolist(), strict=True))

    def residual_matrix(self, theta: np.ndarray) -> np.ndarray:
        """e(θ) = τ̂(q^f, q̇^f, q̈^f; θ) - τ^f, shape (N, n_joints) [N·m]."""
        tau_hat = self.model.inverse_dynamics(self.qf, self.qdf, self.qddf, self.as_params(theta))
        return np.asarray(tau_hat, dtype=float) - self.tau_f

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """∂e/∂θ for all parameters, shape (N·n_joints, n_params)."""
        jac = self.model.parameter_jacobian(self.qf, self.qdf, self.qddf, self.as_params(theta))
        return np.asarray(jac, dtype=float).reshape(self.tau_f.size, len(self.names))


# ---------------------------------------------------------------------- the steps
def check_settings(est) -> None:
    if est.torque not in ("measured", "pd"):
        raise InputError(f"torque must be 'measured' or 'pd'; got {est.torque!r}.")
    if est.torque != "pd" and (est.kp is not None or est.kd is not None):
        given = [n for n in ("kp", "kd") if getattr(est, n) is not None]
        raise InputError(
            f"{arg('kp')}/{arg('kd')} are used only with {arg('torque', repr('pd'), cli='pd')}; "
            f"got {'/'.join(arg(n) for n in given)} with "
            f"{arg('torque', repr(est.torque), cli=est.torque)} (the measured tau1..taun "
            f"need no gains). Use {arg('torque', repr('pd'), cli='pd')} to rebuild the torque "
            f"from the PD law, or drop {arg('kp')}/{arg('kd')}."
        )
    if est.derivatives not in ("paper", "consistent"):
        raise InputError(f"derivatives must be 'paper' or 'consistent'; got {est.derivatives!r}.")
    if est.start not in ("initial", "linear"):
        raise InputError(f"start must be 'initial' or 'linear'; got {est.start!r}.")
    check_int(est.max_nfev, "max_nfev", minimum=1)
    if est.noise not in NOISE_METHODS:
        raise InputError(f"noise must be one of {NOISE_METHODS}; got {est.noise!r}.")
    check_int(est.noise_replicates, "noise_replicates", minimum=2)
    if est.uncertainty not in STDERR_METHODS:
        raise InputError(f"uncertainty must be one of {STDERR_METHODS}; got {est.uncertainty!r}.")
    for attr in ("xtol", "ftol", "gtol"):
        check_positive(getattr(est, attr), attr)
    for attr in (
        "parameter_names",
        "parameters",
        "n_joints",
        "inverse_dynamics",
        "parameter_jacobian",
    ):
        if not hasattr(est.model, attr):
            raise InputError(
                "model must be a chain model (physid.load_model('manipulator') or a TOML "
                f"chain model); it has no attribute {attr!r} (got "
                f"{type(est.model).__name__})."
            )


def _channels(est, recording, nj: int) -> tuple[list[str], list[str]]:
    """The joint-angle channels and the torque (or reference) channels the fit needs."""
    if not hasattr(recording, "channels") or not hasattr(recording, "select"):
        raise InputError(
            "recording must be a physid Recording (physid.load_recording(path)); got "
            f"{type(recording).__name__}."
        )
    q_names = recording.channels("q")
    q_all = sorted(
        (n for n in recording.names if n[:1] == "q" and n[1:].isdigit() and int(n[1:]) > 0),
        key=lambda n: int(n[1:]),
    )
    gaps = [f"q{k}" for k in range(1, max([int(n[1:]) for n in q_all] + [0]) + 1)]
    gaps = [n for n in gaps if n not in q_all]
    if gaps:
        raise DataFileError(
            f"the recording's joint-angle channels {q_all} have a gap: {gaps} missing "
            f"(the model has {nj} joints and needs q1..q{nj} [rad]). Add or rename the "
            "missing column(s)."
        )
    if not q_names:
        raise DataFileError(
            f"the recording has no joint-angle channels q1..q{nj} [rad]; it has "
            f"{list(recording.names)}. Name the angle columns q1, q2, ... "
            + joint_hint(
                nj, recording.names, dict(zip(recording.names, recording.units, strict=True))
            )
        )
    if len(q_names) != nj:
        raise ShapeError(
            f"the model has {nj} joints but the recording has {len(q_names)} joint-angle "
            f"channel(s) {q_names}; use the model that matches the recording (or select its "
            "channels)."
        )
    prefix = "tau" if est.torque == "measured" else "r"
    needed = [f"{prefix}{i + 1}" for i in range(nj)]
    missing = [n for n in needed if n not in recording.names]
    if missing:
        hint = (
            f"Record the joint torques, or use {arg('torque', repr('pd'), cli='pd')} with "
            "references r1..rn and the PD gains."
            if est.torque == "measured"
            else "Record the references, or use "
            f"{arg('torque', repr('measured'), cli='measured')} with tau1..taun."
        )
        raise DataFileError(
            f"torque={est.torque!r} needs channels {needed}; the recording lacks {missing} "
            f"(it has {list(recording.names)}). {hint}"
        )
    return q_names, needed


def filter_recording(est, recording) -> _Filtered:
    """`filtered_signals` with the chosen filter (M, Ω_g and, for "auto", the reason)."""
    check_settings(est)
    nj = int(est.model.n_joints)
    q_names, needed = _channels(est, recording, nj)
    m = None if est.half_width is None else check_int(est.half_width, "half_width", minimum=1)
    auto = isinstance(est.cutoff, str)
    if auto and est.cutoff != "auto":
        raise InputError(
            f"{arg('cutoff')} must be 'auto' or a number in (0, π] [rad/sample]; got "
            f"{est.cutoff!r}."
        )
    if m is None and not auto:
        m = DEFAULT_HALF_WIDTH
    check_length(
        recording.n_samples,
        2 * int(m) + 1 if m is not None else 2 * MIN_AUTO_HALF_WIDTH + 1,
        f"the input-error filters with half_width={m} "
        f"({2 * int(m or MIN_AUTO_HALF_WIDTH) + 1} taps)",
        "Use a longer record or a smaller half_width= (M).",
    )
    t = recording.t
    dt = recording.dt
    q = recording.select(q_names)
    choice = None
    if auto:
        choice = choose_filter(q, dt, half_width=m)
        m, cutoff = choice.half_width, choice.cutoff
    else:
        cutoff = est.cutoff
    filt = filter_derivatives(q, t, int(m), cutoff, design=est.derivatives)
    cutoff = filt.lowpass.cutoff
    lowpass, t_valid = filt.lowpass, filt.t
    q_f, qd_f, qdd_f = filt.value, filt.first, filt.second
    tau = None
    if est.torque == "measured":
        tau = recording.select(needed)
        tau_f = lowpass.apply(tau)
    else:
        _check_pd_only(recording.metadata)
        kp = _gains(est.kp, "kp", nj, recording.metadata)
        kd = _gains(est.kd, "kd", nj, recording.metadata)
        r_f = lowpass.apply(recording.select(needed))
        tau_f = kp * (r_f - q_f) - kd * qd_f  # τ^f = Kp (r^f - q^f) - Kd q̇^f
    bank = (filt.lowpass, filt.first_filter, filt.second_filter)

    def refilter(q_new, tau_new=None):
        """The same filters on other samples of q (and of the measured τ)."""
        qf_new, qdf_new, qddf_new = (b.apply(q_new) for b in bank)
        if est.torque == "measured":
            tau_new_f = lowpass.apply(tau if tau_new is None else tau_new)
        else:
            tau_new_f = kp * (r_f - qf_new) - kd * qdf_new
        return qf_new, qdf_new, qddf_new, tau_new_f

    return _Filtered(
        t_valid, q_f, qd_f, qdd_f, tau_f, float(dt), q, int(m), cutoff, choice, refilter, tau
    )


def check_band(est, f: _Filtered, notes: list[str], *, stacklevel: int = 3):
    """The filter-band check before a fit: the motion must lie in the flat part of the pass band.

    Warns (`FilterWarning`, at ``stacklevel``) when it does not, saying in which direction to move
    the cut-off, and appends the text to ``notes``. Returns ``(band, advice)``: the
    `FilterBandCheck` and the automatic filter choice (None when none was needed).
    """
    band = filter_band_check(f.q, f.half_width, f.cutoff, f.dt)
    advice = f.choice
    if est.check_filter and not band.ok:
        advice = advice or choose_filter(f.q, f.dt, half_width=f.half_width)
        motion_fits = advice.signal_band <= band.passband_edge
        worst = int(np.argmax(band.fractions))
        head = (
            f"{100 * band.fractions[worst]:.2g} % of the energy of q{worst + 1}'s rate lies "
            f"above {band.passband_edge:.3g} rad/sample, where the low-pass filter "
            f"(M={f.half_width}, Ω_g={f.cutoff:.4g}) is no longer flat"
        )
        if not motion_fits:  # too low: the motion itself is cut, the fit is biased
            text = (
                f"{head}; the motion reaches {advice.signal_band:.3g} rad/sample, so the "
                "filtered equations of motion will not balance and the estimates will be "
                f"biased. Raise the cut-off to Ω_g >= {advice.cutoff:.3g} for this M (or "
                "raise M), or use cutoff='auto'; see docs/input-error.md."
            )
        else:  # the energy above the band is noise: raising Ω_g would only add noise
            text = (
                f"{head}, but that energy is measurement noise (σ ≈ "
                f"{np.max(advice.noise_std):.2g} on q), not motion: the motion stays below "
                f"{advice.signal_band:.3g} rad/sample. Do not raise the cut-off (more noise "
                "in q̈^f biases the inertias towards zero); the lowest that holds the "
                f"motion is Ω_g = {advice.cutoff:.3g} for this M (cutoff='auto')."
            )
        if f.choice is None or not motion_fits:
            warnings.warn(text, FilterWarning, stacklevel=stacklevel)
            notes.append(text)
    return band, advice


def _start_values(est, initial, names) -> tuple[dict[str, float], dict[str, float]]:
    """Starting values of every parameter, and those held by the user or by the model.

    ``fixed=`` values and names, ``initial=``, and the parameters the model marks known
    (``identify = false``: not in ``model.unknown``), which are held at their values unless
    ``fixed=`` or ``initial=`` name them (``initial=`` asks to estimate from there).
    """
    model = est.model
    fixed_values, hold = _fixed_spec(est.fixed, names)
    given = _initial_values(initial, names)
    _check_initial_vs_fixed(given, fixed_values)
    start_values = dict(model.parameters)
    start_values.update(given)
    start_values.update(fixed_values)
    user_fixed = fixed_values | {n: float(start_values[n]) for n in hold}
    unknown = set(getattr(model, "unknown", names) or ())
    for n in names:
        if n not in unknown and n not in user_fixed and n not in given:
            user_fixed[n] = float(start_values[n])
    return start_values, user_fixed


def _hold(est, model, start_values, user_fixed, notes):
    """Structural identifiability and the hold plan: ``(structural, fixed)``.

    Each unidentifiable combination that ``user_fixed`` does not touch gets one parameter held
    (an `IdentifiabilityWarning`, also in ``notes``), or, with ``hold_unidentifiable=False``, an
    `IdentifiabilityError`.
    """
    structural: StructuralIdentifiability = structural_identifiability(model, start_values)
    if structural.combinations and not est.hold_unidentifiable:
        unresolved = [c for c in structural.combinations if not set(c.parameters) & set(user_fixed)]
        if unresolved:
            first = unresolved[0].parameters[-1]
            raise IdentifiabilityError(
                "; ".join(c.text for c in unresolved)
                + ": the data cannot separate them. Fix one of each, e.g. "
                f"{arg('fixed', f'{{{first!r}: VALUE}}', cli=f'{first}=VALUE')}, or allow "
                f"{arg('hold_unidentifiable', 'True')}."
            )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fixed = hold_plan(structural, start_values, user_fixed, warn=True)
    for w in caught:
        warnings.warn(w.message, w.category, stacklevel=4)
        notes.append(str(w.message))
    return structural, fixed


def prepare(est, recording, initial) -> _Problem:
    """Filtered signals, filter-band check, hold plan, bounds, start and the residual maps."""
    model = est.model
    f = filter_recording(est, recording)
    t_valid, qf, qdf, qddf, tau_f, dt = f.t, f.qf, f.qdf, f.qddf, f.tau_f, f.dt
    names = tuple(model.parameter_names)
    p = len(names)
    start_values, user_fixed = _start_values(est, initial, names)
    notes: list[str] = []
    if f.choice is not None:
        notes.append(f.choice.reason)

    band, advice = check_band(est, f, notes, stacklevel=4)
    structural, fixed = _hold(est, model, start_values, user_fixed, notes)
    start_values.update(fixed)
    free_idx = [i for i, n in enumerate(names) if n not in fixed]
    if not free_idx:
        raise InputError("every parameter is fixed; leave at least one free.")
    theta0 = np.array([start_values[n] for n in names], dtype=float)
    scale = np.where(theta0 != 0.0, np.abs(theta0), 1.0)

    lower = np.where(theta0 > 0, 1e-6 * theta0, -np.inf)
    upper = np.full(p, np.inf)
    if est.bounds:
        for name, pair in _check_bounds(est.bounds, names).items():
            i = names.index(name)
            lower[i], upper[i] = pair
    if np.any((theta0 < lower) | (theta0 > upper)):
        bad = [
            n for n, v, lo, hi in zip(names, theta0, lower, upper, strict=True) if not lo <= v <= hi
        ]
        raise InputError(
            f"initial value(s) of {bad} lie outside their bounds; change {arg('initial')} or "
            f"{arg('bounds')}."
        )
    problem = _Problem(
        model=model,
        filtered=f,
        advice=advice,
        names=names,
        t=t_valid,
        qf=qf,
        qdf=qdf,
        qddf=qddf,
        tau_f=tau_f,
        dt=float(dt),
        band=band,
        structural=structural,
        fixed=fixed,
        free_idx=free_idx,
        theta0=theta0,
        scale=scale,
        lower=lower,
        upper=upper,
        notes=notes,
    )
    # -- numerical identifiability at the start: refuse what the data cannot determine
    problem.before = numeric_identifiability(
        problem.jacobian(theta0)[:, free_idx],
        problem.free_names,
        scale[free_idx],
        beta_names=getattr(model, "beta_names", None),
    )
    raise_if_not_excited(problem.before, "at the initial values")
    return problem


def predict_torque(
    model,
    params,
    recording,
    *,
    half_width: int,
    cutoff: float,
    derivatives: str = "paper",
    dt: float | None = None,
    measured: bool = False,
):
    """τ̂ = τ(q^f, q̇^f, q̈^f; θ) on a recording, with the input-error fit's own filters.

    Parameters
    ----------
    model : ChainModel
    params : mapping name -> float
        The model's own parameters (`InputErrorResult.model_parameters`).
    recording : Recording
        ``t`` [s], ``q1..qn`` [rad | m] (``tau1..taun`` [N·m | N] with ``measured=True``).
    half_width : int
        M of the fit [samples].
    cutoff : float [rad/sample]
        Ω_g of the fit.
    derivatives : {"paper", "consistent"}
        The derivative filters' design (`physid.filters.filter_derivatives`).
    dt : float, optional [s]
        The fit's sample period: a recording sampled otherwise is refused (the filters are
        defined per sample, so on another period they would be other filters in Hz).
    measured : bool
        Also return the recording's torques through the same low-pass (``tau1_measured..``).

    Returns
    -------
    Recording
        The filter's valid samples; ``tau1..taun`` predicted (then the measured ones).
        Peak memory: a few float64 copies of q (n_samples × n_joints).

    Raises
    ------
    InputError
        Another sample period than ``dt``; a missing torque channel with ``measured=True``.
    DataFileError, ShapeError
        Missing or extra joint-angle channels.
    """
    from ...signals.recording import Recording

    if not isinstance(recording, Recording):
        raise InputError(f"recording must be one physid Recording; got {type(recording).__name__}.")
    nj = int(model.n_joints)
    q_names = [f"q{j + 1}" for j in range(nj)]
    missing = [n for n in q_names if n not in recording.names]
    if missing:
        raise DataFileError(
            f"the recording lacks the joint-angle channel(s) {missing} (it has "
            f"{list(recording.names)}); the model has {nj} joints and needs q1..q{nj}."
        )
    if dt is not None and not np.isclose(recording.dt, float(dt), rtol=1e-6, atol=0):
        raise InputError(
            f"the recording is sampled every {recording.dt:g} s but the fit used {float(dt):g} "
            "s; resample it to the fit's period (Recording.resample), or refit."
        )
    tau_names = [f"tau{j + 1}" for j in range(nj)]
    if measured and not all(n in recording.names for n in tau_names):
        raise InputError(
            f"measured=True needs the torque channels {tau_names}; the recording has "
            f"{list(recording.names)}."
        )
    m = check_int(half_width, "half_width", minimum=1)
    check_length(
        recording.n_samples,
        2 * m + 1,
        f"the fit's filters (half_width={m}, {2 * m + 1} taps)",
        "Use a longer record.",
    )
    filt = filter_derivatives(recording.select(q_names), recording.t, m, cutoff, design=derivatives)
    tau_hat = np.asarray(
        model.inverse_dynamics(filt.value, filt.first, filt.second, params), dtype=float
    )
    return torque_recording(
        model,
        filt.t,
        tau_hat,
        filt.lowpass.apply(recording.select(tau_names)) if measured else None,
        metadata={
            "prediction": "inverse model on the signals filtered as in the input-error fit",
            "half_width": m,
            "cutoff": float(filt.lowpass.cutoff),
            "derivatives": derivatives,
        },
    )
