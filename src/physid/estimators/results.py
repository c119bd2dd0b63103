"""One result schema for every estimator.

Every estimator returns a frozen dataclass that mixes in `ResultMixin`. Whatever the method, a
result has

``names``
    The fitted parameters, in column order of ``history``.
``parameters``
    name -> value of the *fitted* parameters only (SI units).
``derived``
    name -> value of quantities computed from them (for the MSD: ``natural_frequency`` [rad/s],
    ``damping_ratio``; with a force input also ``mass``, ``damping``, ``stiffness``).
``stderr``
    name -> standard error of each fitted parameter, or ``None`` when the method cannot give an
    honest one; then ``stderr_reason`` says why.
``derived_stderr`` (where a result has it: the linear-ODE estimators)
    name -> standard error of each derived quantity (delta method), ``None`` whenever
    ``stderr`` is; `summary` and `to_pandas` show it.
``history``
    The estimates per step (a sample for the sliding-window and recursive methods, a residual
    evaluation for input-error), shape (n_steps, n_columns).
``success``, ``message``
    ``success`` is False whenever an estimate is NaN, unsupported or not explained by the data;
    ``message`` says why and what to change.
``units``
    name -> unit of every entry of ``parameters`` and ``derived``.

and the methods `summary()`, `to_dict()` (JSON-ready: every field above and the result's own),
`to_pandas()` (pandas is optional), ``plot(..., ax=None)`` and ``predict(recording)``.

The dict returned by ``to_dict()`` is also the result file format read back by
`physid.analysis.validation.load_result` (see docs/validation.md).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import InputError

__all__ = [
    "ResultMixin",
    "ParameterDict",
    "jsonable",
    "save_result",
    "RESULT_FORMAT",
    "RESULT_FORMAT_VERSION",
    "RENAMED_KEYS",
    "upgrade_result_dict",
]

#: Name and version of the result file format written by ``to_dict()`` (``physid estimate
#: --save``) and read by `physid.analysis.validation.load_result`.
RESULT_FORMAT = "physid-result"
RESULT_FORMAT_VERSION = 1

#: Keys of the result file format that were renamed: old name -> current name. Files written
#: before keep being read (`upgrade_result_dict`): IDIM results wrote their base parameters'
#: expressions as ``expressions``, the key input-error's results call ``base_expressions``.
RENAMED_KEYS = {"expressions": "base_expressions"}

#: The keys every result's ``to_dict()`` carries (the contract every estimator, the CLI and the
#: result files share).
SCHEMA_KEYS = (
    "names",
    "parameters",
    "derived",
    "stderr",
    "stderr_reason",
    "units",
    "success",
    "message",
)


def jsonable(value: Any) -> Any:
    """Convert numpy scalars/arrays, mappings and dataclasses into JSON-ready Python objects.

    Parameters
    ----------
    value : object
        Any nesting of dataclasses, mappings, sequences, numpy arrays and scalars.

    Returns
    -------
    object
        The same structure with lists, dicts, floats, ints, bools and strings only; non-finite
        floats become ``None`` (JSON has no NaN).

    Examples
    --------
    >>> jsonable({"a": np.array([1.0, np.nan]), "b": np.int64(2)})
    {'a': [1.0, None], 'b': 2}
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    return value


def upgrade_result_dict(data: Mapping[str, Any]) -> dict[str, Any]:
    """A result file's dictionary with every renamed key (`RENAMED_KEYS`) under its current name.

    Parameters
    ----------
    data : mapping
        The JSON object of a result file (``to_dict()`` of any version).

    Returns
    -------
    dict
        A copy; a key found under its old name is moved to the current one (a current key,
        when both are present, wins).

    Examples
    --------
    >>> upgrade_result_dict({"expressions": {"ZZ1R": "ZZ1 + YY2"}})
    {'base_expressions': {'ZZ1R': 'ZZ1 + YY2'}}
    """
    out = dict(data)
    for old, new in RENAMED_KEYS.items():
        if old in out:
            value = out.pop(old)
            out.setdefault(new, value)
    return out


class ParameterDict(dict):
    """``parameters``: the fitted values, with a deprecated look-up of derived quantities.

    Before the one result schema, the algebraic and recursive results put ``natural_frequency``
    and ``damping_ratio`` into ``parameters``. They now live in ``derived``; reading them through
    ``parameters[...]`` still works and warns (`DeprecationWarning`), ``parameters.get(...)``
    falls back to them quietly.
    Iteration, ``len``, ``in`` and JSON see the fitted parameters only.

    Parameters
    ----------
    fitted : mapping
        name -> fitted value.
    derived : mapping, optional
        name -> derived value (the deprecated fall-back).

    Examples
    --------
    >>> p = ParameterDict({"theta1": 0.1}, {"natural_frequency": 11.5})
    >>> list(p), "natural_frequency" in p
    (['theta1'], False)
    """

    def __init__(self, fitted: Mapping[str, float], derived: Mapping[str, float] | None = None):
        super().__init__(fitted)
        self._derived = dict(derived or {})

    def __missing__(self, key):
        if key in self._derived:
            warnings.warn(
                f"result.parameters[{key!r}] is deprecated: derived quantities moved to "
                f"result.derived[{key!r}] (parameters holds the fitted parameters only).",
                DeprecationWarning,
                stacklevel=2,
            )
            return self._derived[key]
        raise KeyError(key)

    def get(self, key, default=None):
        # ``get`` falls back to the derived values without a warning: code that asks for a name
        # in parameters first and derived second (e.g. report.style.final_value) stays quiet
        if key in self:
            return super().get(key)
        return self._derived.get(key, default)

    def __reduce__(self):  # pickle (process pools) keeps the fall-back
        return (ParameterDict, (dict(self), self._derived))


class ResultMixin:
    """The shared behaviour of result dataclasses (see the module docstring for the schema).

    A subclass provides (as fields or properties) ``names``, ``parameters``, ``success`` and
    ``message``; and, where it has them, ``derived``, ``stderr``, ``stderr_reason``, ``units``
    and ``history``; fields too large for JSON are listed in ``_history_fields`` (left out of
    ``to_dict(history=False)``), and fields that are not data (a model object) in
    ``_private_fields``; those that do not pickle (a rigid-body model's compiled kernels) in
    ``_unpicklable_fields``, which a pickled result (e.g. from a process pool) holds as None.
    ``method`` names the estimator (``"algebraic"``, ``"rls"``, …).
    """

    # (no ``method`` default here: a dataclass subclass with a ``method`` field would inherit it
    # as the field's default)
    _history_fields: tuple[str, ...] = ()
    _private_fields: tuple[str, ...] = ()
    _unpicklable_fields: tuple[str, ...] = ()

    def __init_subclass__(cls, **kwargs):
        # a dataclass keeps a __repr__ its class defines: give each subclass the short one
        # before @dataclass would write its field-by-field repr (arrays of every sample)
        super().__init_subclass__(**kwargs)
        if "__repr__" not in cls.__dict__:
            cls.__repr__ = ResultMixin.__repr__

    def __repr__(self) -> str:
        from ._display import plain_repr

        return plain_repr(self, self._schema())

    def _repr_html_(self) -> str:
        """A notebook table: each value with its standard error, 95 % interval and unit."""
        from ._display import html_table

        return html_table(self, self._schema())

    def __getstate__(self):
        state = dict(self.__dict__)
        state.update(dict.fromkeys(self._unpicklable_fields))
        return state

    # ------------------------------------------------------------------ schema accessors
    def _schema(self) -> dict[str, Any]:
        return {
            "names": tuple(getattr(self, "names", ()) or ()),
            "parameters": dict(getattr(self, "parameters", {}) or {}),
            "derived": dict(getattr(self, "derived", {}) or {}),
            "stderr": getattr(self, "stderr", None),
            "stderr_reason": getattr(self, "stderr_reason", None),
            "units": dict(getattr(self, "units", {}) or {}),
            "success": bool(getattr(self, "success", False)),
            "message": str(getattr(self, "message", "") or ""),
        }

    def to_dict(self, history: bool = False) -> dict[str, Any]:
        """JSON-ready dictionary of the result.

        Parameters
        ----------
        history : bool
            Include the per-sample (or per-evaluation) arrays.

        Returns
        -------
        dict
            ``format``, ``method``, the schema keys (``names``, ``parameters``, ``derived``,
            ``stderr``, ``stderr_reason``, ``units``, ``success``, ``message``) and every field of
            the result; NaN becomes ``None``.
        """
        out: dict[str, Any] = {
            "format": RESULT_FORMAT,
            "format_version": RESULT_FORMAT_VERSION,
            "method": getattr(self, "method", "") or type(self).__name__,
        }
        out.update(jsonable(self._schema()))
        fields = dataclasses.fields(self) if dataclasses.is_dataclass(self) else ()
        for f in fields:
            if f.name in out or f.name in self._private_fields:
                continue
            if not history and f.name in self._history_fields:
                continue
            out[f.name] = jsonable(getattr(self, f.name))
        return out

    def summary(self) -> str:
        """A short human-readable table of the estimates.

        Returns
        -------
        str
            One line per fitted parameter (value ± standard error and unit), one per derived
            quantity, the message.
        """
        schema = self._schema()
        params, derived = schema["parameters"], schema["derived"]
        stderr = schema["stderr"] or {}
        units = schema["units"]
        lines = [f"{type(self).__name__}: {'success' if schema['success'] else 'FAILED'}"]
        width = max((len(k) for k in [*params, *derived]), default=4)
        for name, value in params.items():
            se = stderr.get(name)
            se_txt = f"  ± {se:.3g}" if se is not None and np.isfinite(se) else ""
            unit = f"  [{units[name]}]" if units.get(name) else ""
            lines.append(f"  {name:<{width}} = {value:.8g}{se_txt}{unit}")
        derived_se = getattr(self, "derived_stderr", None) or {}
        for name, value in derived.items():
            unit = f"  [{units[name]}]" if units.get(name) else ""
            se = derived_se.get(name)
            se_txt = f"  ± {se:.3g}" if se is not None and np.isfinite(se) else ""
            lines.append(f"  {name:<{width}} = {value:.8g}{se_txt}  (derived){unit}")
        if schema["stderr"] is None and schema["stderr_reason"]:
            lines.append(f"  no standard errors: {schema['stderr_reason']}")
        from ._display import fit_text

        if fit_text(self):
            lines.append(f"  {fit_text(self)} (output-error fit on the fitted record)")
        if schema["message"]:
            lines.append(f"  {schema['message']}")
        return "\n".join(lines)

    def to_pandas(self):
        """The estimates as a `pandas.DataFrame` (needs the optional ``pandas`` package).

        Returns
        -------
        pandas.DataFrame
            Index: the fitted and the derived names; columns ``value``, ``stderr``, ``unit`` and
            ``kind`` (``"fitted"`` or ``"derived"``).

        Raises
        ------
        InputError
            pandas is not installed (``pip install physid[pandas]``).
        """
        try:
            import pandas as pd
        except ImportError:
            raise InputError(
                "to_pandas() needs pandas, which is not installed; install it with "
                "`pip install physid[pandas]` (or `pip install pandas`), or use to_dict()."
            ) from None
        schema = self._schema()
        stderr = schema["stderr"] or {}
        derived_se = getattr(self, "derived_stderr", None) or {}  # delta method, where given
        rows = []
        for kind, values in (("fitted", schema["parameters"]), ("derived", schema["derived"])):
            for name, value in values.items():
                se = stderr.get(name) if kind == "fitted" else derived_se.get(name)
                rows.append(
                    {
                        "name": name,
                        "value": float(value),
                        "stderr": float("nan") if se is None else float(se),
                        "unit": schema["units"].get(name, ""),
                        "kind": kind,
                    }
                )
        return pd.DataFrame(rows, columns=["name", "value", "stderr", "unit", "kind"]).set_index(
            "name"
        )

    def predict(self, recording):
        """The model's prediction on another recording (see each result's own method).

        Parameters
        ----------
        recording : Recording
            Held-out data with the channels the fit used.

        Returns
        -------
        Recording
            Predicted channels.
        """
        raise InputError(f"{type(self).__name__} does not implement predict().")


def save_result(
    result, path, *, model=None, recording=None, model_options=None, gains=None, feedforward=None
) -> str:
    """Write a result file (JSON) that `load_result` and ``physid validate`` read back.

    Parameters
    ----------
    result : ResultMixin
        A fitted result.
    path : str or Path
        Destination (written atomically; never over ``recording``).
    model : str, optional
        How to load the model again: a built-in name (``"msd"``) or a model file path (made
        absolute). Default: the result's ``model_name``.
    recording : str, optional
        The recording the result was fitted on (kept for reference).
    model_options : mapping, optional
        The options `physid.load_model` was given for the fitted model (``kinetic="paper"``,
        ``strict=True``, ...), written as ``"model_options"`` so that `load_result` loads the
        same model. Default: taken from the result's model where it carries one (a chain's
        ``kinetic``), else not recorded (`load_result` then uses the defaults and
        ``validate`` says so in a note).
    gains : mapping, optional
        PD gains given explicitly to the fit, ``{"kp": [...], "kd": [...]}`` (one value per
        joint; ``torque="pd"`` of input-error, IDIM-IV's closed loop), written as ``"gains"``;
        ``validate`` rebuilds the torque with them instead of the held-out record's metadata.
    feedforward : {None, "none", "gravity", "gravity+friction"}
        The feed-forward given explicitly to the fit (IDIM-IV's closed loop), written as
        ``"feedforward"``; ``validate`` re-simulates that controller unless told otherwise.

    Returns
    -------
    str
        The path written.
    """
    import json
    from pathlib import Path

    from .._paths import atomic_write

    data = result.to_dict()
    ref = model if model is not None else getattr(result, "model_name", "") or ""
    if ref and Path(str(ref)).suffix:  # a file path: absolute, so the file can be moved
        ref = str(Path(str(ref)).resolve())
    data["model"] = ref
    if model_options is None:
        model_options = _model_options_of(getattr(result, "model", None))
    if model_options is not None:
        if not isinstance(model_options, Mapping):
            raise InputError(
                f"model_options must be a mapping of load_model options (kinetic=..., "
                f"strict=...); got {type(model_options).__name__}."
            )
        data["model_options"] = jsonable(dict(model_options))
    if gains is not None:
        if not isinstance(gains, Mapping) or set(gains) - {"kp", "kd"}:
            raise InputError(f"gains must be a mapping with keys 'kp' and/or 'kd'; got {gains!r}.")
        data["gains"] = {
            k: None if v is None else [float(x) for x in np.ravel(v)] for k, v in gains.items()
        }
    if feedforward is not None:
        from ..simulate.feedforward import FEEDFORWARD

        if not isinstance(feedforward, str) or feedforward not in FEEDFORWARD:
            raise InputError(
                f"feedforward must be one of {sorted(FEEDFORWARD)}; got {feedforward!r}."
            )
        data["feedforward"] = feedforward
    if recording is not None:
        data["recording"] = str(Path(str(recording)).resolve())
        if Path(str(recording)).resolve() == Path(path).resolve():
            raise InputError(
                f"the result file {str(path)!r} is the recording it was fitted on; write the "
                "result to another file."
            )
    text = json.dumps(data, indent=1, allow_nan=False)
    atomic_write(path, lambda fh: fh.write(text + "\n"))
    return str(path)


def _model_options_of(model) -> dict | None:
    """The `load_model` options that rebuild ``model`` (None: cannot tell from the object)."""
    if model is None:
        return None
    if hasattr(model, "a_names"):  # linear ODE: the result holds every coefficient
        return {}
    kinetic = getattr(model, "kinetic", None)
    if any(c.__name__ == "RigidBodyModel" for c in type(model).__mro__):  # exact T only
        return {}
    return {"kinetic": kinetic} if kinetic in ("exact", "paper") else None
