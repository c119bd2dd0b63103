"""The TOML tables of a linear-ODE model file (``kind = "linear_ode"``): the top level and [ode]."""

from __future__ import annotations

import math

import numpy as np

from ..errors import ModelFileError, PhysidError
from ._locate import _where
from .spec_common import _parse_recording
from .spec_types import LinearODESpec


def _parse_linear_ode(data, text, source, name, params) -> LinearODESpec:
    """The linear-ODE tables of a parsed TOML file as a `LinearODESpec`."""
    allowed_top = {"name", "kind", "description", "parameters", "ode", "recording"}
    extra = set(data) - allowed_top
    if extra:
        raise ModelFileError(
            f"{_where(source, text, 'top level', sorted(extra)[0])}: unknown key(s) "
            f"{sorted(extra)} "
            f"for a linear_ode model; allowed: {sorted(allowed_top)}."
        )
    ode = data.get("ode")
    if not isinstance(ode, dict):
        raise ModelFileError(
            f"{source}: a linear_ode model needs an [ode] table with a = [a_0, ..., a_(n-1)] and "
            f"b = [b_0, ..., b_m] (parameter names; a_n = 1)."
        )
    names = {p.name for p in params}
    allowed_ode = {"a", "b", "input", "output", "output_offset", "input_unit", "output_unit"}
    extra = set(ode) - allowed_ode
    if extra:
        raise ModelFileError(
            f"{_where(source, text, 'ode', sorted(extra)[0], table='ode')}: unknown key(s) "
            f"{sorted(extra)} in [ode]; allowed: {sorted(allowed_ode)}."
        )
    out: dict = {}
    expressions: dict = {}
    for key in ("a", "b"):
        out[key] = _ode_coefficients(key, ode.get(key), names, expressions, text, source)
    if len(out["b"]) > len(out["a"]):
        raise ModelFileError(
            f"{_where(source, text, 'ode.b', 'b', table='ode')}: the input order m = "
            f"{len(out['b']) - 1} "
            f"must be below the output order n = {len(out['a'])} (a strictly proper model); drop "
            f"entries from b or add entries to a."
        )
    _check_nominal_coefficients(expressions, params, text, source)
    offset = _ode_offset(ode, out, names, text, source)
    units = _ode_units(ode, text, source)
    return LinearODESpec(
        name=name,
        parameters=params,
        a=out["a"],
        b=out["b"],
        input_name=str(ode.get("input", "u")),
        output_name=str(ode.get("output", "x")),
        description=str(data.get("description", "")),
        source=source,
        expressions=tuple(expressions.items()),
        output_offset=offset,
        input_unit=units["input_unit"],
        output_unit=units["output_unit"],
        recording=tuple(_parse_recording(data, text, source).items()),
    )


def _ode_coefficients(key, seq, names, expressions, text, source) -> tuple:
    """The coefficient names of ``ode.a`` or ``ode.b``; each expression entry is recorded in
    ``expressions`` under a fresh coefficient name (``a0``, ``b1``, ...)."""
    where = _where(source, text, f"ode.{key}", key, table="ode")
    if (
        not isinstance(seq, list)
        or not seq
        or not all(
            isinstance(s, str) or (isinstance(s, (int, float)) and not isinstance(s, bool))
            for s in seq
        )
    ):
        example = '["theta2", "theta1"] or ["k/m", "c/m"]' if key == "a" else '["1/m"]'
        raise ModelFileError(
            f"{where}: {key} must be a non-empty list of parameter names or expressions of "
            f"them, e.g. {example}; got {seq!r}."
        )
    coefs = []
    for i, entry in enumerate(seq):
        if not isinstance(entry, str) and not math.isfinite(float(entry)):
            raise ModelFileError(
                f"{where}: entry {i} of ode.{key} is {float(entry)} (a number beyond float64's "
                "range, or nan); give a finite coefficient."
            )
        entry_text = repr(float(entry)) if not isinstance(entry, str) else entry.strip()
        if entry_text in names:
            coefs.append(entry_text)
            continue
        from ..expressions import FUNCTION_NAMES, expression_names

        try:
            used, called = expression_names(entry_text, source=f"{where}[{i}]")
        except PhysidError as exc:
            raise ModelFileError(str(exc)) from None
        bad_calls = [f for f in called if f not in FUNCTION_NAMES]
        if bad_calls:
            raise ModelFileError(
                f"{where}: unknown function(s) {bad_calls} in ode.{key} (entry {i}: "
                f"{entry_text!r}); allowed: {', '.join(FUNCTION_NAMES)}."
            )
        unknown_names = [u for u in used if u not in names and u != "pi"]
        if unknown_names:
            shown = repr(unknown_names[0]) if len(unknown_names) == 1 else unknown_names
            raise ModelFileError(
                f"{where}: unknown symbol "
                f"{shown} in "
                f"ode.{key} (entry {i}: {entry_text!r}); declare each under [parameters] "
                f"({unknown_names[0]} = {{ value = ..., identify = true }}). Known: "
                f"{sorted(names)}."
            )
        coef = f"{key}{i}"
        while coef in names or coef in expressions:
            coef += "_"
        expressions[coef] = entry_text
        coefs.append(coef)
    return tuple(coefs)


def _check_nominal_coefficients(expressions: dict, params, text, source) -> None:
    """Refuse coefficient expressions that are not finite at the parameters' nominal values,
    with the file and line of the ``a``/``b`` list (the model could not be built there)."""
    from ..expressions import evaluate_expression

    values = {p.name: float(p.value) for p in params}
    for coef, entry in expressions.items():
        key = coef[0]
        with np.errstate(all="ignore"):
            try:
                value = float(evaluate_expression(entry, values))
            except (ArithmeticError, ValueError):
                value = float("nan")
        if not math.isfinite(value):
            where = _where(source, text, f"ode.{key}", key, table="ode")
            raise ModelFileError(
                f"{where}: coefficient {entry!r} (entry {coef[1:].rstrip('_')} of ode.{key}) is "
                f"{value} at the nominal parameter values; give values under [parameters] at "
                "which it is finite (no division by zero)."
            )


def _ode_offset(ode, out, names, text, source):
    """The ``output_offset`` parameter name (None: no offset), checked against the coefficients."""
    offset = ode.get("output_offset")
    if offset is not None and (not isinstance(offset, str) or offset not in names):
        raise ModelFileError(
            f"{_where(source, text, 'ode.output_offset', 'output_offset', table='ode')}: "
            f'output_offset must name a declared parameter (e.g. output_offset = "offset" '
            f'with offset = {{ value = 0.0, unit = "m" }} under [parameters]); got {offset!r}.'
        )
    if offset is not None and offset in set(out["a"] + out["b"]):
        raise ModelFileError(
            f"{_where(source, text, 'ode.output_offset', 'output_offset', table='ode')}: "
            f"output_offset {offset!r} is also a coefficient; declare a separate parameter."
        )
    return offset


def _ode_units(ode, text, source) -> dict:
    """``input_unit`` and ``output_unit`` of ``[ode]``, each checked by `physid.units.parse_unit`."""
    units = {}
    for key in ("input_unit", "output_unit"):
        value = ode.get(key, "")
        if not isinstance(value, str):
            raise ModelFileError(f'{source}: ode.{key} must be a unit string such as "N".')
        if value:
            from ..units import parse_unit

            try:
                parse_unit(value)
            except PhysidError as exc:
                where = _where(source, text, f"ode.{key}", key, table="ode")
                raise ModelFileError(f"{where}: {exc}") from None
        units[key] = value
    return units
