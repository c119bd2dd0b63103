"""Which of a file's columns is likely the channel physid needs: the map line that would fix it.

An error such as "the recording needs an input channel 'u' … it has ['Force', 'Displacement']"
is only half a message; the other half is the line that fixes it, ``--map u=Force,x=Displacement``
on the command line or ``channels={'u': 'Force', 'x': 'Displacement'}`` in Python. `guess_map`
matches the channels a model needs to the file's columns by unit (a column in N is a force, one
in mm a length) and by name (``Force``, ``pos``, ``torque_2``), and `map_hint` words the fix with
an argument mark (`physid.errors.arg`), so each interface shows its own syntax.

This module sits in the foundation layer: it knows a few common unit spellings itself and
imports nothing of physid but `physid.errors`.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

from .errors import arg

__all__ = ["KIND_WORDS", "unit_kind", "guess_map", "map_hint", "joint_hint"]

#: Quantity kind → words a column of that kind is often named with (lower case).
KIND_WORDS: dict[str, tuple[str, ...]] = {
    "time": ("time", "t", "zeit", "sec", "seconds", "timestamp"),
    "force": ("force", "kraft", "f", "load", "input", "u", "fz", "fx", "effort"),
    "acceleration": ("acc", "accel", "acceleration", "a", "u"),
    "length": ("displacement", "disp", "position", "pos", "x", "y", "dist", "distance", "output"),
    "angle": ("angle", "q", "theta", "pos", "position", "joint", "phi"),
    "torque": ("torque", "tau", "moment", "trq", "effort", "current"),
}

_UNIT_KINDS = {
    "time": {"s", "ms", "us", "µs", "min", "h"},
    "force": {"n", "kn", "mn", "lbf", "newton"},
    "acceleration": {"m/s^2", "m/s²", "m/s/s", "m s^-2", "g"},
    "length": {"m", "mm", "cm", "um", "µm", "in", "inch", "ft", "km"},
    "angle": {"rad", "deg", "°", "degree", "degrees", "mrad"},
    "torque": {"n·m", "nm", "n*m", "n m", "n.m", "knm", "n·mm", "nmm"},
}


def unit_kind(unit: str) -> str | None:
    """The quantity kind of a unit string (``"mm"`` → ``"length"``), or None if not known.

    Parameters
    ----------
    unit : str
        A unit as a file header writes it (``"N"``, ``"N·m"``, ``"deg"``).

    Returns
    -------
    str or None
        One of the keys of `KIND_WORDS`.

    Examples
    --------
    >>> unit_kind("kN"), unit_kind("N·m"), unit_kind("V")
    ('force', 'torque', None)
    """
    text = str(unit or "").strip().lower()
    for kind, spellings in _UNIT_KINDS.items():
        if text in spellings:
            return kind
    return None


def _name_score(column: str, kinds: Iterable[str], channel: str) -> int:
    words = [w for w in re.split(r"[^a-z0-9]+|(?<=[a-z])(?=[0-9])", column.lower()) if w]
    if column.lower() == channel.lower():
        return 3
    for kind in kinds:
        if any(w in KIND_WORDS.get(kind, ()) for w in words):
            return 1
    return 0


def _index(channel: str) -> str:
    match = re.search(r"(\d+)$", channel)
    return match.group(1) if match else ""


def guess_map(
    wanted: Mapping[str, Iterable[str]],
    names: Iterable[str],
    units: Mapping[str, str] | None = None,
) -> dict[str, str]:
    """The likely source column of each wanted channel the file lacks.

    Parameters
    ----------
    wanted : mapping of str to iterable of str
        Channel physid needs → the quantity kinds it may have (``{"u": ("force",),
        "x": ("length",)}``); kinds are keys of `KIND_WORDS`.
    names : iterable of str
        The file's channels.
    units : mapping of str to str, optional
        Unit of each channel (``{"Force": "N"}``); a matching unit counts more than a name.

    Returns
    -------
    dict
        Channel → column, for the channels that are missing and have a likely match; each column
        is used at most once, the first best match in column order wins (``q1``, ``q2``, …
        take angle columns in order; a numbered column prefers the channel's own number).
    """
    names = list(names)
    units = dict(units or {})
    used = {c for c in wanted if c in names}
    out: dict[str, str] = {}
    for channel, kinds in wanted.items():
        if channel in names:
            continue
        kinds = tuple(kinds)
        best, best_score = None, 0
        for column in names:
            if column in used or column in wanted:
                continue
            score = 2 * (unit_kind(units.get(column, "")) in kinds) + _name_score(
                column, kinds, channel
            )
            if score and _index(channel) and _index(column) == _index(channel):
                score += 1
            if score > best_score:
                best, best_score = column, score
        if best is not None:
            out[channel] = best
            used.add(best)
    return out


def _cli_map(mapping: Mapping[str, str]) -> str:
    text = ",".join(f"{k}={v}" for k, v in mapping.items())
    return text if re.fullmatch(r"[\w.,=/+-]+", text) else f"'{text}'"  # * and [ ] for the shell


def map_hint(mapping: Mapping[str, str], placeholder: Mapping[str, str] | None = None) -> str:
    """A marked "map them with …" phrase: ``--map u=Force`` (CLI) or ``channels={...}`` (Python).

    Parameters
    ----------
    mapping : mapping of str to str
        Channel → source column (from `guess_map`).
    placeholder : mapping of str to str, optional
        Shown instead when ``mapping`` is empty (``{"u": "COLUMN"}``).

    Returns
    -------
    str
        Text with a `physid.errors.arg` mark for ``channels`` (the CLI shows it as ``--map``),
        or "" when there is nothing to suggest.

    Examples
    --------
    >>> from physid.errors import InputError
    >>> e = InputError("no u. " + map_hint({"u": "Force", "x": "Displacement"}))
    >>> str(e)
    "no u. The file's columns suggest channels={'u': 'Force', 'x': 'Displacement'}."
    >>> e.render({"channels": "--map"})
    "no u. The file's columns suggest --map u=Force,x=Displacement."
    """
    shown = dict(mapping) or dict(placeholder or {})
    if not shown:
        return ""
    what = "The file's columns suggest" if mapping else "Map them from the file's columns, e.g."
    return f"{what} {arg('channels', repr(shown), cli=_cli_map(shown))}."


def joint_hint(n_joints: int, names: Iterable[str], units: Mapping[str, str] | None = None) -> str:
    """`map_hint` for an arm's channels ``q1..qn`` (angles or lengths) and ``tau1..taun``.

    Parameters
    ----------
    n_joints : int
        Joints of the model.
    names : iterable of str
        The file's channels.
    units : mapping of str to str, optional
        Unit of each channel.

    Returns
    -------
    str
        Marked text (see `map_hint`), e.g. ``--map q1=angle_1,tau1=torque_1``.

    Examples
    --------
    >>> from physid.errors import InputError
    >>> text = joint_hint(2, ["t", "pos1", "pos2", "trq1", "trq2"])
    >>> InputError(text).render({"channels": "--map"})
    "The file's columns suggest --map q1=pos1,q2=pos2,tau1=trq1,tau2=trq2."
    """
    wanted: dict[str, tuple[str, ...]] = {}
    for j in range(1, n_joints + 1):
        wanted[f"q{j}"] = ("angle", "length")
    for j in range(1, n_joints + 1):
        wanted[f"tau{j}"] = ("torque", "force")
    names = list(names)
    guess = guess_map(wanted, names, units)
    placeholder = {c: f"COLUMN{c[-1]}" for c in list(wanted)[:2] if c not in names}
    return map_hint(guess, placeholder)
