"""Result files read back (`load_result`, `LoadedResult`): the model, its parameters and how the
fit was set up, enough to predict and validate."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...errors import DataFileError, InputError, arg
from ...estimators.results import RESULT_FORMAT, upgrade_result_dict
from .inverse import _chain_inverse
from .result_file import read_result_json

__all__ = ["LoadedResult", "load_result"]


@dataclass(frozen=True)
class LoadedResult:
    """A result read back from its file: enough to predict and validate.

    Attributes
    ----------
    method : str
        ``"algebraic"``, ``"rls"``, ``"input-error"``, …
    model : LinearODEModel or ChainModel
        The model, loaded from the file's reference (or ``model=`` given to `load_result`).
    parameters, derived, stderr, units : dict
        As in the result schema (``stderr`` may be None).
    data : dict
        The whole file.
    model_options : dict or None
        The `load_model` options the model was loaded with (the file's ``"model_options"``);
        None when the file does not record them (an older file): the model was then loaded
        with its defaults, which `validate` notes.
    """

    method: str
    model: Any
    parameters: dict[str, float]
    derived: dict[str, float] = field(default_factory=dict)
    stderr: dict[str, float] | None = None
    units: dict[str, str] = field(default_factory=dict)
    data: dict[str, Any] = field(default_factory=dict, repr=False)
    model_options: dict[str, Any] | None = None

    @property
    def is_linear(self) -> bool:
        """Whether the model is a linear ODE (algebraic / RLS results)."""
        return hasattr(self.model, "a_names")

    @property
    def coefficients(self) -> dict[str, float]:
        """Every coefficient value of a linear ODE result (known and fitted)."""
        return {**dict(self.data.get("known") or {}), **self.parameters}

    def predict(self, recording):
        """The model's prediction on ``recording`` (see `validate` for what is predicted).

        Parameters
        ----------
        recording : Recording
            Held-out data.

        Returns
        -------
        Recording
            Linear ODE: the input and the simulated output. Chains: the inverse-model torques
            ``tau1..`` on the filtered signals (time = the filter's valid samples).
        """
        if self.is_linear:
            from ...estimators._linear import predict_recording

            return predict_recording(self.model, self.coefficients, recording)
        from ...signals.recording import Recording

        t, _, tau_hat = _chain_inverse(self, recording)
        names = [f"tau{j + 1}" for j in range(tau_hat.shape[1])]
        return Recording(t, tau_hat, names, metadata={"prediction": "inverse model, filtered"})


def load_result(path, *, model=None) -> LoadedResult:
    """Read a result file written by ``physid estimate --save`` / `save_result`.

    Parameters
    ----------
    path : str or Path
        The JSON result file.
    model : str, Path or model object, optional
        The model, when the file does not name one (or to override it). A name or path is
        loaded with the file's ``"model_options"`` (``kinetic``, ``strict``, ... as in the
        fit); a model object is used as it is.

    Returns
    -------
    LoadedResult

    Raises
    ------
    DataFileError
        The file is not JSON or not a physid result file.
    InputError
        No model is named (pass ``model=``; CLI ``--model``).
    """
    from ...models import load_model

    p = Path(path)
    data = read_result_json(p)  # size, nesting and every key's type checked, naming the key
    if data.get("format", RESULT_FORMAT) != RESULT_FORMAT:
        raise DataFileError(f"{str(p)!r} has format {data.get('format')!r}, not {RESULT_FORMAT!r}.")
    data = upgrade_result_dict(data)  # keys renamed since the file was written
    ref = model if model is not None else data.get("model") or data.get("model_name")
    if not ref:
        raise InputError(
            f"the result file {str(p)!r} names no model; pass {arg('model', '...', cli='MODEL')}."
        )
    options = data.get("model_options")
    if options is not None and not isinstance(options, dict):
        raise DataFileError(f"{str(p)!r}: 'model_options' must be an object; got {options!r}.")
    if isinstance(ref, (str, Path)) and model is None and Path(str(ref)).suffix:
        beside = p.parent / str(ref)  # a relative path: the result file's folder first
        if not Path(str(ref)).is_absolute() and beside.exists():
            ref = str(beside)
        if not Path(str(ref)).exists():  # the result file was moved to another machine
            raise InputError(
                f"the result file {str(p)!r} names the model file {str(ref)!r}, which does not "
                f"exist here; pass the model ({arg('model', '...', cli='MODEL')})."
            )
    if isinstance(ref, (str, Path)):
        try:  # the model that was fitted, not its defaults
            mdl = load_model(ref, **(options or {}))
        except InputError as exc:
            if not options:
                raise
            raise DataFileError(
                f"{str(p)!r}: its 'model_options' {json.dumps(options)}: {exc}"
            ) from None
    else:
        mdl = ref
    method = str(data.get("method", ""))
    if not method:
        method = "algebraic" if hasattr(mdl, "a_names") else "input-error"
    params = {k: float(v) for k, v in data["parameters"].items() if v is not None}
    if len(params) != len(data["parameters"]):
        bad = [k for k, v in data["parameters"].items() if v is None]
        raise DataFileError(f"{str(p)!r}: parameter(s) {bad} are null (the fit failed).")
    _check_complete(p, data, mdl)
    return LoadedResult(
        method=method,
        model=mdl,
        parameters=params,
        derived=dict(data.get("derived") or {}),
        stderr=data.get("stderr"),
        units=dict(data.get("units") or {}),
        data=data,
        model_options=None if options is None else dict(options),
    )


def _check_complete(p, data, model) -> None:
    """Refuse a result file that lacks a value the model needs (a truncated file): never fill
    it in with the model's nominal value."""
    params = data["parameters"]
    listed = [*(data.get("names") or ()), *(data.get("free") or ())]
    if hasattr(model, "a_names"):  # a linear ODE: every coefficient, fitted or known
        listed += [*model.a_names, *model.b_names]
        have = {**dict(data.get("known") or {}), **params}
        where = "'parameters' or 'known'"
    elif str(data.get("method", "")).startswith("idim") or data.get("parameter_set") == "base":
        have, where = params, "'parameters'"  # base parameters: those the file lists
    else:  # a chain's own parameters: estimated or held
        listed += list(getattr(model, "parameter_names", ()))
        have = {**dict(data.get("fixed") or {}), **params}
        where = "'parameters' or 'fixed'"
    missing = list(dict.fromkeys(n for n in listed if n not in have))
    if missing:
        shown = ", ".join(missing[:8]) + (
            f" and {len(missing) - 8} more" if len(missing) > 8 else ""
        )
        raise DataFileError(
            f"{str(p)!r}: the result file gives no value for {shown} (in {where}); it is "
            f"truncated or was written for another model than {getattr(model, 'name', '')!r}. "
            "physid does not fill in nominal values: save the fit again, or validate with the "
            f"model it was fitted with ({arg('model', '...', cli='MODEL')})."
        )


def _as_loaded(result, model) -> LoadedResult:
    if isinstance(result, LoadedResult):
        return result
    if isinstance(result, (str, Path)):
        return load_result(result, model=model)
    data = result.to_dict()
    mdl = model if model is not None else getattr(result, "model", None)
    if mdl is None:
        mdl = data.get("model_name")
    if isinstance(mdl, (str, Path)):
        from ...models import load_model

        mdl = load_model(mdl)
    if mdl is None:
        raise InputError(f"validate needs the model: pass {arg('model', '...', cli='MODEL')}.")
    return LoadedResult(
        method=str(data.get("method", "")),
        model=mdl,
        parameters={k: float(v) for k, v in dict(result.parameters).items()},
        derived=dict(data.get("derived") or {}),
        stderr=data.get("stderr"),
        units=dict(data.get("units") or {}),
        data=data,
    )
