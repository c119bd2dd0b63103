"""The plausibility gate every estimator passes before it reports ``success``.

An optimiser that converged, or a least-squares system that was well conditioned, does not make
an estimate the data support. The checks here look at the data and the fit, not at the solver,
and each returns a sentence (what is wrong, with the numbers, and what to change) or nothing:

`constant_channels`
    An output (torque, force, measured response) that never changes: all-zero torques fit every
    parameter as 0 with a residual of exactly 0.
`still_joints`
    Joints whose position never leaves its own noise floor: the parameters that act only
    through that joint's motion (its friction, its rotor inertia) are not in the data.
`flipped_segments`
    The model's prediction follows the output in one part of the record and its mirror image in
    another: the sign of the output or of the gain changed during the record.
`too_perfect`
    A residual at the rounding floor of float64 on an output that carries nothing to explain.
`implausible_scale`
    Estimated masses 100 times (or more) away from the model's nominal ones: a channel in
    another unit than the one assumed (a position in mm read as m), named when it has no unit.

`gate` turns the sentences into ``(success, message)``. The algebraic, recursive, input-error
and IDIM estimators all call it as the last step of their verdict.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "constant_channels",
    "still_joints",
    "flipped_segments",
    "partial_segments",
    "FOLLOW_CORRELATION",
    "MISS_CORRELATION",
    "too_perfect",
    "unchanging",
    "gate",
    "implausible_scale",
    "check_magnitude",
    "MAX_MAGNITUDE",
    "linear_ode_problems",
    "STILL_NOISE_RATIO",
    "FLIP_CORRELATION",
]

#: A joint whose position's standard deviation is below this many times its white-noise floor
#: (`physid.filters.band.noise_floor`) is taken as still: its motion is indistinguishable from
#: the measurement noise (a held joint with σ_q = 1e-4 rad noise: ratio 1.0; the slowest joint
#: of the arm6 README session: ratio above 1e3).
STILL_NOISE_RATIO = 5.0

#: A record is taken as sign-flipped when the correlation of the output with the model's
#: prediction is at least this in one eighth of the record and at most its negative in another
#: (a sound fit: about 1 in every quarter; a gain that changes sign halfway: about -1 after it).
FLIP_CORRELATION = 0.5

# float64 rounding: a relative residual below this is the arithmetic's floor, not a measurement
_ROUNDING = 64 * np.finfo(float).eps


def constant_channels(y, names: Sequence[str]) -> list[str]:
    """Names of the columns of ``y`` that never change (all equal up to float64 rounding).

    Parameters
    ----------
    y : array_like, shape (n_samples, n_channels)
        The measured outputs (torques [N·m], forces [N], a response in its unit).
    names : sequence of str
        One name per column.

    Returns
    -------
    list of str
        The constant columns, in order (empty when every column varies).

    Examples
    --------
    >>> constant_channels(np.c_[np.zeros(5), np.arange(5.0)], ["tau1", "tau2"])
    ['tau1']
    """
    y = np.asarray(y, dtype=float)
    y = y.reshape(y.shape[0], -1)
    if y.shape[0] == 0:
        return []
    with np.errstate(invalid="ignore", over="ignore"):
        spread = np.nanmax(y, axis=0) - np.nanmin(y, axis=0)
        size = np.nanmax(np.abs(y), axis=0)
    flat = ~(spread > _ROUNDING * size)
    return [str(n) for n, f in zip(names, flat, strict=True) if f]


def still_joints(q) -> list[int]:
    """Indices (0-based) of the columns of ``q`` whose motion does not rise above their noise.

    A column is still when its standard deviation is at most `STILL_NOISE_RATIO` times its
    white-noise floor (`physid.filters.band.noise_floor`, from the top of its spectrum) or when
    it is constant up to rounding.

    Parameters
    ----------
    q : array_like, shape (n_samples, n_joints)
        Joint positions [rad or m].

    Returns
    -------
    list of int

    Examples
    --------
    >>> t = np.linspace(0, 5, 5001)
    >>> noise = 1e-4 * np.random.default_rng(0).normal(size=(t.size, 2))
    >>> still_joints(np.c_[np.sin(t), np.zeros_like(t)] + noise)
    [1]
    """
    from ..filters.band import noise_floor

    q = np.asarray(q, dtype=float)
    q = q.reshape(q.shape[0], -1)
    if q.shape[0] < 16:
        return []
    spread = np.std(q, axis=0)
    floor = noise_floor(q)
    size = np.max(np.abs(q), axis=0)
    still = (spread <= STILL_NOISE_RATIO * floor) | (spread <= _ROUNDING * size)
    return [int(j) for j in np.flatnonzero(still)]


def flipped_segments(
    t, y, y_hat, *, name: str = "the output", segments: int = 8, parts=None
) -> str | None:
    """A sentence when the prediction follows ``y`` in one part of the record and ``-y`` in
    another (a sign flip of the output or the gain during the record), else None.

    The record is cut into ``segments`` equal parts; in each, the correlation of ``y`` with
    ``y_hat`` (both about their means in the part) is computed. A flip is reported when one
    part has a correlation of at least `FLIP_CORRELATION` and another at most its negative.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time [s].
    y, y_hat : array_like, shape (n_samples,)
        The measured output and the identified model's prediction of it (same unit).
    name : str
        The output's name, for the sentence.
    segments : int
        Parts of the record compared.
    parts : tuple, optional
        ``(t, edges, correlation, energy)`` already computed (a record read in blocks); then
        ``t`` is only indexed at the edges and ``y``, ``y_hat`` are not used.

    Returns
    -------
    str or None
    """
    if parts is None:
        parts = _segment_correlations(t, y, y_hat, segments)
    if parts is None:
        return None
    t, edges, corr, _ = parts
    if not np.any(np.isfinite(corr)):
        return None
    hi, lo = int(np.nanargmax(corr)), int(np.nanargmin(corr))
    if corr[hi] < FLIP_CORRELATION or corr[lo] > -FLIP_CORRELATION:
        return None
    return (
        f"the identified model predicts {name} during {_span(t, edges, hi)} (correlation "
        f"{corr[hi]:.2f}) but its mirror image during {_span(t, edges, lo)} (correlation "
        f"{corr[lo]:.2f}): the sign of the "
        "output or of the input's gain changed during the record, and no single model explains "
        "both parts. Check the channels' signs and fit each part on its own."
    )


def _segment_correlations(t, y, y_hat, segments: int):
    """``(t, edges, correlation, energy)``: the correlation of ``y`` with ``y_hat`` and the energy
    of ``y`` (about their means) in each of ``segments`` equal parts of the record, as float
    arrays; None when the record is too short for that many parts or not finite."""
    t, y, y_hat = (np.asarray(a, dtype=float).ravel() for a in (t, y, y_hat))
    if y.size < 8 * segments or not (np.all(np.isfinite(y)) and np.all(np.isfinite(y_hat))):
        return None
    edges = np.linspace(0, y.size, segments + 1).astype(int)
    corr = np.full(segments, np.nan)
    energy = np.zeros(segments)
    for k in range(segments):  # a handful of parts, each a vectorised reduction
        a = y[edges[k] : edges[k + 1]]
        b = y_hat[edges[k] : edges[k + 1]]
        a, b = a - a.mean(), b - b.mean()
        energy[k] = float(a @ a)
        den = float(np.linalg.norm(a) * np.linalg.norm(b))
        if den > 0:
            corr[k] = float(a @ b) / den
    return t, edges, corr, energy


def _span(t, edges, k: int) -> str:
    """The time span of part ``k``, as the sentences quote it."""
    return f"{t[edges[k]]:.4g}–{t[edges[k + 1] - 1]:.4g} s"


#: `partial_segments`: the prediction "follows" the output in a part where their correlation is
#: at least this, and "misses" it where the correlation is at most `MISS_CORRELATION` (white
#: output noise at 0 dB SNR still leaves 0.71, at -5 dB 0.49).
FOLLOW_CORRELATION = 0.8
MISS_CORRELATION = 0.35


def partial_segments(
    t, y, y_hat, *, name: str = "the output", segments: int = 8, parts=None
) -> str | None:
    """A sentence when the prediction follows ``y`` closely in one part of the record and misses
    it in at least a quarter of the record where ``y`` moves, else None.

    Parts where the output barely moves (energy below a tenth of the largest part's: a record
    that starts at rest) are not judged. A model that explains only the end of a record whose
    output changed sign, gain or dynamics halfway is caught here, where its prediction is not a
    mirror image (`flipped_segments`) but noise.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time [s].
    y, y_hat : array_like, shape (n_samples,)
        The measured output and the identified model's prediction of it (same unit).
    name : str
        The output's name, for the sentence.
    segments : int
        Parts of the record compared.
    parts : tuple, optional
        ``(t, edges, correlation, energy)`` already computed (a record read in blocks); then
        ``t`` is only indexed at the edges and ``y``, ``y_hat`` are not used.

    Returns
    -------
    str or None
    """
    if parts is None:
        parts = _segment_correlations(t, y, y_hat, segments)
    if parts is None:
        return None
    t, edges, corr, energy = parts
    judged = np.isfinite(corr) & (energy >= 0.1 * energy.max())
    follows = judged & (corr >= FOLLOW_CORRELATION)
    misses = judged & (corr <= MISS_CORRELATION)
    if not follows.any() or misses.sum() < max(2, segments // 4):
        return None
    good = int(np.flatnonzero(follows)[np.argmax(corr[follows])])
    bad = np.flatnonzero(misses)
    spans = ", ".join(_span(t, edges, k) for k in bad[:4])
    return (
        f"the identified model follows {name} during {_span(t, edges, good)} (correlation "
        f"{corr[good]:.2f}) but not during {spans} "
        f"(correlation at most {np.max(corr[bad]):.2f}), where the output moves as much: the "
        "system, or the sign or gain of a channel, changed during the record, and no single "
        "model explains it. Check the channels and fit each part on its own."
    )


def too_perfect(residual, y, names: Sequence[str]) -> str | None:
    """A sentence when the residual is at the float64 rounding floor because ``y`` carries
    nothing to explain (constant columns), else None.

    Parameters
    ----------
    residual, y : array_like, shape (n_samples, n_channels)
        The fit's residual and the output it was fitted to (same unit).
    names : sequence of str
        One name per column.

    Returns
    -------
    str or None
    """
    y = np.asarray(y, dtype=float)
    y = y.reshape(y.shape[0], -1)
    e = np.asarray(residual, dtype=float).reshape(y.shape[0], -1)
    flat = constant_channels(y, names)
    if not flat:
        return None
    scale = max(float(np.max(np.abs(y))), np.finfo(float).tiny)
    rel = float(np.max(np.abs(e))) / scale if e.size else 0.0
    if not np.isfinite(rel) or rel > _ROUNDING * max(1, y.shape[0]):
        return None
    shown = ", ".join(flat[:6]) + (f", … ({len(flat)} in all)" if len(flat) > 6 else "")
    return (
        f"the fit is exact to rounding (largest residual {rel:.2g} of the output) because "
        f"{shown} never change(s): the data hold nothing for the parameters to explain."
    )


def unchanging(y, names: Sequence[str], what: str = "output") -> str | None:
    """A sentence naming the columns of ``y`` that never change (`constant_channels`), or None.

    Parameters
    ----------
    y : array_like, shape (n_samples, n_channels)
        The measured outputs.
    names : sequence of str
        One name per column.
    what : str
        What the columns are, for the sentence ("torque", "output").

    Returns
    -------
    str or None
    """
    flat = constant_channels(y, names)
    if not flat:
        return None
    shown = ", ".join(flat[:6]) + (f", … ({len(flat)} in all)" if len(flat) > 6 else "")
    return (
        f"the {what} {shown} never change(s) (constant over the whole record): a measured "
        f"{what} of a system in motion varies, so the channel is missing, zeroed or mapped "
        "wrongly, and the parameters fitted to it mean nothing. Check the channel map and the "
        "file."
    )


def linear_ode_problems(model, values, t, u, y) -> list[str | None]:
    """The gate's sentences for a linear-ODE fit: an output that never changes, and a sign
    flip during the record (`flipped_segments` on the open-loop prediction of the whole record).

    Parameters
    ----------
    model : LinearODEModel
        The identified model.
    values : mapping
        Every coefficient's value (fitted and known), SI.
    t, u, y : array_like, shape (n_samples,)
        Time [s], the input and the measured output (their units).

    Returns
    -------
    list of (str or None)
    """
    from ._linear import simulate_prediction

    y = np.asarray(y, dtype=float)
    out_name = getattr(model, "output_name", "y")
    problems: list[str | None] = [unchanging(y[:, None], [out_name])]
    if problems[0] is None and all(np.isfinite(float(v)) for v in values.values()):
        with np.errstate(all="ignore"):
            y_hat, _ = simulate_prediction(model, values, t, u, y)
        label = f"the output {out_name}"
        flip = flipped_segments(t, y, y_hat, name=label)
        problems.append(flip or partial_segments(t, y, y_hat, name=label))
    return problems


#: Largest magnitude of a signal the linear-ODE estimators accept: their standard errors use
#: fourth powers of the signals (the variance of a variance), which overflow float64 above
#: about 1e77.
MAX_MAGNITUDE = 1e60


def check_magnitude(signals, names: Sequence[str]) -> None:
    """Refuse signals whose magnitude would overflow the estimators' arithmetic.

    Parameters
    ----------
    signals : sequence of array_like
        The channels (any unit).
    names : sequence of str
        One name per channel.

    Raises
    ------
    InputError
        A channel with a value above `MAX_MAGNITUDE`, naming it and the fix.
    """
    from ..errors import InputError

    for x, name in zip(signals, names, strict=True):
        with np.errstate(invalid="ignore"):
            big = float(np.nanmax(np.abs(np.asarray(x, dtype=float)), initial=0.0))
        if big > MAX_MAGNITUDE:
            raise InputError(
                f"channel {name!r} reaches {big:.3g}, above {MAX_MAGNITUDE:.0e}: the estimate's "
                "standard errors take fourth powers of the signals, which overflow float64. "
                "Rescale the channel (record it in a larger unit, e.g. with a [unit] header or "
                "the channel map's scale factor)."
            )


def implausible_scale(parameters, model, recordings=(), units=None) -> list[str]:
    """Sentences for estimated masses 100 times (or more) away from the model's nominal values.

    A fit on a position logged in mm and read as m converges to masses 1000 times too small;
    only the scale gives it away (`physid.signals.io.plausibility.implausible_estimates`). The
    position channels the recordings carry without a unit are named as the likely culprits,
    with the likely unit.

    Parameters
    ----------
    parameters : mapping of str to float
        Estimates that are standard parameters of ``model`` (a base parameter that stands for
        a sum of several is left out by the caller).
    model : model
        With ``parameters`` (nominal values) and ``units``; any other model gives ``[]``.
    recordings : sequence of Recording
        The fitted recordings.
    units : mapping of str to str, optional
        Units of the estimates, over the model's.

    Returns
    -------
    list of str
        One sentence per implausible estimate, with both numbers and the likely unit.

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> model = NS(parameters={"m1": 18.0}, units={"m1": "kg"})
    >>> implausible_scale({"m1": 0.018}, model)[0][:57]
    'm1 = 0.018 kg is 1000 times below the model nominal 18 kg'
    """
    import re

    from ..signals.io.plausibility import implausible_estimates

    nominal = getattr(model, "parameters", None)
    if not isinstance(nominal, dict):
        return []
    all_units = dict(getattr(model, "units", None) or {})
    all_units.update(units or {})
    unitless = sorted(
        {
            n
            for rec in recordings
            for n in rec.names
            if re.fullmatch(r"q\d+", n)
            and not rec.unit(n)
            and n not in (rec.metadata.get("original_units") or {})
        }
    )
    return implausible_estimates(parameters, nominal, all_units, unitless)


def gate(success: bool, message: str, problems: Sequence[str | None]) -> tuple[bool, str]:
    """``(success, message)`` after the plausibility checks' sentences ``problems``.

    Any non-empty sentence makes ``success`` False and leads the message (the solver's own
    message follows).

    Examples
    --------
    >>> gate(True, "converged.", [None, "tau6 never changes."])
    (False, 'Implausible: tau6 never changes. converged.')
    """
    found = [p for p in problems if p]
    if not found:
        return success, message
    head = "Implausible: " + " ".join(found)
    return False, f"{head} {message}".strip()
