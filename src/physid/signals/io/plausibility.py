"""Is a channel in the unit physid assumes? A joint's positions and speeds against the model's
limits, for channels whose file gave no unit (a log in mm or deg read as SI is off by 1000 or 57,
and a fit on it is a silent wrong answer)."""

from __future__ import annotations

import math

import numpy as np

from ...errors import arg

__all__ = ["implausible_units", "likely_unit"]

#: A joint's data beyond this multiple of the model's limit are called implausible.
LIMIT_FACTOR = 10.0

_REVOLUTE = (("deg", math.pi / 180), ("mrad", 1e-3), ("arcmin", math.pi / 10800))
_PRISMATIC = (("mm", 1e-3), ("cm", 1e-2), ("um", 1e-6))


def _unit_fix(j: int, unit: str) -> str:
    """How to give q{j} a unit: a header, or the channel map (marked, so each interface shows
    its own spelling: ``channels={...}`` in Python, ``--map`` on the command line)."""
    entry = arg("channels", f"{{'q{j}': 'SOURCE [{unit}]'}}", cli=f"'q{j}=SOURCE [{unit}]'")
    return f"a header 'q{j} [{unit}]' or {entry}"


def likely_unit(ratio: float, prismatic: bool) -> str:
    """The unit whose scale best explains data ``ratio`` times the model's (log distance).

    Parameters
    ----------
    ratio : float > 0
        Data magnitude over the model's (e.g. largest |q| over the largest joint limit).
    prismatic : bool
        A length (mm, cm, µm) rather than an angle (deg, mrad, arcmin).

    Returns
    -------
    str
        E.g. ``"mm"`` for ratios near 1000, ``"deg"`` near 57.

    Examples
    --------
    >>> likely_unit(850.0, True), likely_unit(40.0, False)
    ('mm', 'deg')
    """
    table = _PRISMATIC if prismatic else _REVOLUTE
    # the data in unit u are 1/scale times the SI values: ratio ≈ 1/scale (a span below the
    # limits' is common, so the closest in log among the units larger than the ratio's half)
    return min(table, key=lambda us: abs(math.log10(ratio * us[1])))[0]


def implausible_units(rec, joint_types, limits, *, source: str | None = None) -> list[str]:
    """Messages for joint channels without a unit that exceed the model's limits 10-fold.

    Parameters
    ----------
    rec : Recording
        Channels ``q1..qn`` (and ``qd1..qdn``, else q's finite differences) in the units the
        file gave; those with a unit in the file (``metadata["original_units"]`` or a unit on
        the channel) are trusted and not checked.
    joint_types : sequence of str
        ``"revolute"``/``"prismatic"``/``"continuous"`` per joint.
    limits : mapping
        ``"position"`` (n, 2) and ``"velocity"`` (n,) [rad, m, rad/s, m/s]; NaN or inf: none.
    source : str, optional
        The file, for the message.

    Returns
    -------
    list of str
        One message per channel found implausible, with both numbers and the likely unit.
    """
    if not joint_types or not limits:
        return []
    position = np.asarray(limits.get("position", np.full((len(joint_types), 2), np.nan)), float)
    velocity = np.asarray(limits.get("velocity", np.full(len(joint_types), np.nan)), float)
    prefix = f"{source}: " if source else ""
    out = []
    for j, kind in enumerate(joint_types, start=1):
        prismatic = str(kind).lower().startswith("p")
        si = "m" if prismatic else "rad"
        q = _unitless(rec, f"q{j}")
        if q is None:
            continue
        row = np.abs(position[j - 1]) if position.ndim == 2 else np.array([np.nan])
        bound = float(np.max(row[np.isfinite(row)])) if np.isfinite(row).any() else np.nan
        peak = float(np.max(np.abs(q)))
        if np.isfinite(bound) and bound > 0 and peak > LIMIT_FACTOR * bound:
            unit = likely_unit(peak / bound, prismatic)
            out.append(
                f"{prefix}channel 'q{j}' has no unit and reaches {peak:.4g}, {peak / bound:.3g} "
                f"times the model's joint limit {bound:.4g} {si}: is it in {unit}? Give the unit "
                f"({_unit_fix(j, unit)}); a fit on it is wrong."
            )
            continue  # the speed of the same channel says the same
        vlim = float(velocity[j - 1]) if velocity.size >= j else np.nan
        speed = _unitless(rec, f"qd{j}")
        if speed is None and rec.n_samples > 2:
            speed = np.gradient(q, rec.t)
        if speed is None or not (np.isfinite(vlim) and vlim > 0):
            continue
        top = float(np.max(np.abs(speed)))
        if top > LIMIT_FACTOR * vlim:
            unit = likely_unit(top / vlim, prismatic)
            out.append(
                f"{prefix}joint {j} moves at up to {top:.4g} {si}/s by its channels without unit, "
                f"{top / vlim:.3g} times the model's velocity limit {vlim:.4g} {si}/s: is q{j} in "
                f"{unit}? Give the unit ({_unit_fix(j, unit)})."
            )
    return out


def _unitless(rec, name):
    """The channel's values if the file gave it no unit (None otherwise or if absent)."""
    if name not in rec.names:
        return None
    original = (rec.metadata.get("original_units") or {}).get(name)
    if original or rec.unit(name):
        return None
    return np.asarray(rec[name], dtype=float)


#: An estimated mass this many times away from the model's nominal one is called implausible.
ESTIMATE_FACTOR = 100.0


def implausible_estimates(parameters, nominal, units, unitless=()) -> list[str]:
    """Messages for estimated masses 100 times (or more) away from the model's nominal values.

    A position logged in mm and read as m makes the accelerations 1000 times too large, so the
    masses come out 1000 times too small (the estimate of a log in mm of an 18 kg axis is 0.018
    kg): the fit converges, and only the scale gives it away.

    Parameters
    ----------
    parameters : mapping of str to float
        The estimates (a fit's ``parameters``).
    nominal : mapping of str to float
        The model's nominal values (``model.parameters``).
    units : mapping of str to str
        Units of the parameters; only those in ``kg`` are compared.
    unitless : sequence of str
        Position channels the file gave without a unit, named as the likely culprits.

    Returns
    -------
    list of str

    Examples
    --------
    >>> implausible_estimates({"m1": 0.018}, {"m1": 18.0}, {"m1": "kg"}, ["q1"])[0][:57]
    'm1 = 0.018 kg is 1000 times below the model nominal 18 kg'
    """
    out = []
    for name, value in parameters.items():
        ref = nominal.get(name)
        if units.get(name) != "kg" or ref is None or not (float(ref) > 0):
            continue
        ratio = float(value) / float(ref)
        if ratio <= 0 or 1 / ESTIMATE_FACTOR < ratio < ESTIMATE_FACTOR:
            continue
        way = f"{1 / ratio:.4g} times below" if ratio < 1 else f"{ratio:.4g} times above"
        guess = ""
        if ratio < 1 and unitless:
            unit = "mm" if 1 / ratio > 300 else "cm" if 1 / ratio > 30 else "deg"
            guess = (
                f" The channel(s) {', '.join(unitless)} have no unit in the file: in {unit}? "
                f"(a position in {unit} read as SI scales the accelerations up and the masses "
                "down by the same factor)"
            )
        out.append(
            f"{name} = {float(value):.4g} kg is {way} the model nominal {float(ref):.4g} kg; "
            f"check the units of the channels.{guess}"
        )
    return out
