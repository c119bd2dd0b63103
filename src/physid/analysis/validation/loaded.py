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
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataFileError(
            f"cannot read the result file {str(p)!r}: {exc}. Give the file written by "
            "physid.estimators.results.save_result (the estimate command's save option)."
        ) from None
    if not isinstance(data, dict) or not isinstance(data.get("parameters"), dict):
        raise DataFileError(
            f"{str(p)!r} is not a physid result file (no 'parameters' object); write one with "
            "physid.estimators.results.save_result (the estimate command's save option)."
        )
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
        mdl = load_model(ref, **(options or {}))  # the model that was fitted, not its defaults
    else:
        mdl = ref
    method = str(data.get("method", ""))
    if not method:
        method = "algebraic" if hasattr(mdl, "a_names") else "input-error"
    params = {k: float(v) for k, v in data["parameters"].items() if v is not None}
    if len(params) != len(data["parameters"]):
        bad = [k for k, v in data["parameters"].items() if v is None]
        raise DataFileError(f"{str(p)!r}: parameter(s) {bad} are null (the fit failed).")
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
