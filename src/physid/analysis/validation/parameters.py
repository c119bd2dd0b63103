"""What a result file holds, read back as the model's parameters: an IDIM result's base model on
its kept columns, an input-error result's estimates and held values, and the fit's stiction
threshold."""

from __future__ import annotations

from ...errors import InputError, arg


def _is_idim(loaded) -> bool:
    return str(loaded.method).startswith("idim")


def _idim_threshold(loaded) -> tuple[float, bool]:
    """The fit's ``stick_threshold`` and whether the result records it (else the default)."""
    from ...estimators._stiction import STICK_THRESHOLD

    value = loaded.data.get("stick_threshold")
    if value is None:  # written before the fit recorded it: that physid's default rule
        return STICK_THRESHOLD, False
    return (value if isinstance(value, str) else float(value)), True


def _idim_parameters(loaded) -> dict[str, float]:
    """Standard parameters of an IDIM result's fitted base model: each base value on its kept
    column (``columns``), 0 on every other column (``τ = Y θ = W_b β``)."""
    from ...estimators.idim import base_regressor_info

    d = loaded.data
    free = list(d.get("names") or loaded.parameters)
    columns = list(d.get("columns") or base_regressor_info(loaded.model).independent)
    return _base_theta(loaded, free, columns)


def _base_theta(loaded, free, columns) -> dict[str, float]:
    """Every standard parameter of ``loaded.model``: each base value (``free``, read from
    ``loaded.parameters``) on its kept column (``columns``), 0 on every other column."""
    names = tuple(loaded.model.parameter_names)
    missing = [n for n in free if n not in loaded.parameters]
    if missing or len(columns) != len(free) or not set(columns) <= set(names):
        raise InputError(
            "the result's base parameters do not match the model "
            f"{getattr(loaded.model, 'name', '')!r} (values missing for {missing[:4]}, or "
            "kept columns the model does not have); validate with the model the result "
            f"was fitted with ({arg('model', '...', cli='MODEL')})."
        )
    theta = dict.fromkeys(names, 0.0)
    theta.update({c: float(loaded.parameters[n]) for n, c in zip(free, columns, strict=True)})
    return theta


def _input_error_parameters(loaded) -> dict[str, float]:
    """The model's own parameters of an input-error result file (every one of them).

    Over the model's parameters: the estimates and the held ones. Over base parameters
    (``parameter_set="base"``, named ``mcx1R``…): each base value on its kept column
    (``columns``) and 0 on the others, ``τ = Y θ = W_b β`` (as
    `InputErrorResult.model_parameters`). Files written before base names existed keyed the
    kept columns themselves and held the others at 0 in ``fixed``; they read as before.
    """
    d = loaded.data
    names = tuple(loaded.model.parameter_names)
    if d.get("parameter_set") == "base" and d.get("columns"):
        free = list(d.get("free") or d.get("names") or loaded.parameters)
        return _base_theta(loaded, free, list(d["columns"]))
    params = {**dict(d.get("fixed") or {}), **loaded.parameters}
    unknown = [k for k in params if k not in names]
    if d.get("parameter_set") == "base" and unknown:  # never drop a fitted value silently
        raise InputError(
            f"the result file's base parameters {unknown[:4]} are not parameters of the model "
            f"{getattr(loaded.model, 'name', '')!r} and the file has no 'columns' to place them; "
            "refit with this physid to write them."
        )
    return {k: v for k, v in params.items() if k in names}
