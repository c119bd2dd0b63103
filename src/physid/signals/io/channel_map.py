"""Channel maps over a file's variables: which names an entry uses, whether a default entry
applies, and the values of an arithmetic entry (`physid.expressions`, over SI values)."""

from __future__ import annotations

import re

import numpy as np

from ...errors import DataFileError, InputError, PhysidError
from ...units import parse_unit
from .conversion import _split_map_unit


def _missing_names(body: str, available) -> list[str]:
    """The names an expression (or a bare variable) uses that are not in ``available``."""
    body, _ = _split_map_unit(body)
    if body in available:
        return []
    from ...expressions import expression_names

    try:
        names, _ = expression_names(body)
    except PhysidError:
        return []  # a dotted struct path or a syntax error: the normal path explains it
    return [name for name in names if name not in available and name != "pi"]


def _default_entry(path, target, text, available, has_target, source, shown):
    """Whether a channel-defaults entry applies (True) or is dropped (False); or raise."""
    missing = _missing_names(text, available)
    if not missing:
        return True
    if has_target:
        return False
    raise DataFileError(
        f"{path}: {source} maps {target} = {text!r}, but the file has no variable "
        f"{', '.join(repr(m) for m in missing)} and no channel {target!r}; its variables are "
        f"{shown}. Correct that entry, or map the channel from the file's variables with "
        f"channels={{{target!r}: 'NAME'}}."
    )


def _expression_names(body: str, variables) -> tuple[str, ...]:
    """The variables (dotted struct paths included) that an expression mentions."""
    return tuple(
        name
        for name in variables
        if name in body and re.search(rf"(?<![\w.]){re.escape(name)}(?![\w.])", body)
    )


def _expression_values(
    path, variables, n, target, body, columns=None, scalars=None, row_label=None
):
    """Evaluate a channel-map expression over the file's channels (in SI) and scalars."""
    from ...expressions import evaluate_expression

    if columns is None:  # time: over the raw numeric vectors and scalars
        table = {}
        for name, var in variables.items():
            if var.value is not None and var.value.size == 1:
                table[name] = float(var.value.reshape(-1)[0])
            elif var.value is not None and var.value.ndim == 1:
                table[name] = var.value.astype(float)
    else:
        table = dict(scalars or {})
        for name, (values, unit) in columns.items():
            if values is None:
                continue
            try:
                table[name] = parse_unit(unit).scale * values if unit else values
            except InputError:
                table[name] = values  # an unknown unit: the expression sees the raw numbers
    from ...errors import ExpressionError

    try:
        with np.errstate(all="ignore"):
            value = evaluate_expression(body, table, source=f"{path}: channels[{target!r}]")
    except ExpressionError as exc:
        if exc.reason != "unknown_name":
            raise
        arrays = [k for k, v in table.items() if np.ndim(v) > 0]
        numbers = [k for k, v in table.items() if np.ndim(v) == 0]
        shown = arrays[:30] + (["..."] if len(arrays) > 30 else [])
        raise ExpressionError(
            f"{path}: channels[{target!r}] = {body!r}: the file has no variable "
            f"{', '.join(repr(n) for n in exc.names)}; its channels are {shown}"
            + (f" and its scalars {numbers[:20]}" if numbers else "")
            + ". Check the spelling (MATLAB struct fields are written data.pos).",
            reason="unknown_name",
            names=exc.names,
            text=body,
            source=str(path),
        ) from None
    value = np.asarray(value, dtype=float)
    if value.ndim == 0 or value.size == 1 and n != 1:
        raise DataFileError(
            f"{path}: channels[{target!r}] = {body!r} is a constant ({float(value):g}); a "
            "channel needs one value per sample: use at least one channel of the file in it."
        )
    value = value.reshape(-1) if value.ndim > 1 and 1 in value.shape else value
    if value.ndim != 1 or (n and value.size != n):
        raise DataFileError(
            f"{path}: channels[{target!r}] = {body!r} has shape {value.shape}, not one value "
            f"per time sample ({n},)."
        )
    bad = ~np.isfinite(value)
    if bad.any():
        i = int(np.argmax(bad))
        raise DataFileError(
            f"{path}: channels[{target!r}] = {body!r} is {value[i]} at "
            f"{row_label(i) if row_label else f'sample {i}'} "
            f"({int(bad.sum())} non-finite value(s)); check for a division by zero or a "
            "logarithm of a negative value."
        )
    return value
