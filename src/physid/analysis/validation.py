"""Is the identified model any good? Cross-validation on held-out data and residual analysis.

Three tests, the ones robotics and system-identification practice use:

(a) **Inverse-model cross-test** — the forces/torques the model predicts from the held-out motion,
    against the measured ones: relative error ``‖τ̂ − τ‖ / ‖τ‖`` per channel and overall
    (``‖τ̂ − τ‖_F / ‖τ‖_F`` over all channels), computed on the same filtered (and, for
    input-error, decimated by the filter's valid range) signals the fit used: the robotics
    convention (Gautier; Swevers et al.); for IDIM with the fit's stiction rule (a Coulomb
    joint's equations near rest dropped, ``stick_threshold``). For a linear ODE the "force" is
    the input ``u`` and the derivatives come from the state-variable filter at the RLS fit's
    cut-off (the algebraic estimator does not filter; its cross-test uses the RLS default
    cut-off, and says so), the estimated output offset subtracted from ``y`` first.
(b) **Output-error test** — the identified model simulated on the held-out input (open loop for a
    linear ODE, with the initial state fitted by least squares as MATLAB ``compare`` does; closed
    loop with the recording's PD controller ``kp``, ``kd`` and reference ``r`` for chains; an
    IDIM result without a consistent estimate as its fitted base model, each base value on its
    kept column and 0 on the others), and the fit ``100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖)`` per output
    (MATLAB ``compare``'s NRMSE fit) and the relative error ``‖y − ŷ‖ / ‖y‖``.
(c) **Residual analysis** (MATLAB ``resid``) — the normalised autocorrelation of the residual at
    lags 1…25 and its cross-correlation with the input at lags −25…25, against the 99 % band
    ``± 2.576 / √N`` of a white residual independent of the input, and a one-line verdict. The
    residual is the output error of (b) for linear ODEs and the inverse-model error of (a) for
    chains.

Relative errors are fractions (0.01 = 1 %); fits are percent, as MATLAB prints them.

`load_result` reads the result file written by ``physid estimate --save`` (or
`physid.estimators.results.save_result`); `validate` runs the three tests.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataFileError, InputError, arg
from ..estimators.results import RESULT_FORMAT, jsonable, upgrade_result_dict

__all__ = [
    "LoadedResult",
    "ValidationReport",
    "load_result",
    "validate",
    "residual_analysis",
    "fit_percent",
    "MAX_LAG",
    "BAND_Z",
]

#: Lags of the residual tests (MATLAB ``resid``'s default).
MAX_LAG = 25
#: Two-sided 99 % quantile of the standard normal: the band is ``± BAND_Z / √N``.
BAND_Z = 2.5758293035489004

_LINEAR_METHODS = ("algebraic", "rls")


def fit_percent(y, y_hat) -> float:
    """MATLAB ``compare``'s fit: ``100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖)`` [%].

    Parameters
    ----------
    y, y_hat : array_like, shape (n_samples,)
        Measured and predicted output.

    Returns
    -------
    float
        100 for a perfect prediction, 0 for one no better than the mean, negative when worse;
        NaN when ``y`` is constant or ``ŷ`` is not finite.

    Examples
    --------
    >>> fit_percent([0.0, 1.0, 2.0], [0.0, 1.0, 2.0]), fit_percent([0.0, 1.0, 2.0], [1.0, 1.0, 1.0])
    (100.0, 0.0)
    """
    y = np.asarray(y, dtype=float)
    y_hat = np.asarray(y_hat, dtype=float)
    spread = float(np.linalg.norm(y - y.mean()))
    if spread == 0.0 or not np.all(np.isfinite(y_hat)):
        return float("nan")
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / spread)


def _relative(err, ref) -> float:
    den = float(np.linalg.norm(ref))
    return float(np.linalg.norm(err)) / den if den > 0 else float("nan")


# --------------------------------------------------------------------------- residual analysis
def residual_analysis(residual, inputs=None, *, max_lag: int = MAX_LAG) -> dict[str, Any]:
    """Whiteness and independence tests of a residual (MATLAB ``resid``).

    Parameters
    ----------
    residual : array_like, shape (n_samples,) or (n_samples, n_outputs)
        Prediction errors; each column is tested.
    inputs : array_like, shape (n_samples,) or (n_samples, n_inputs), optional
        The input(s) for the cross-correlation test.
    max_lag : int
        Lags ``1..max_lag`` (autocorrelation) and ``−max_lag..max_lag`` (cross-correlation).

    Returns
    -------
    dict
        ``lags`` (the cross-correlation lags), ``band`` (``BAND_Z / √N``, the 99 % band),
        ``autocorrelation`` (per residual column: lags 0..max_lag, 1 at lag 0),
        ``cross_correlation`` (per residual × input pair: lags −max_lag..max_lag),
        ``autocorrelation_outside`` / ``cross_correlation_outside`` (lags outside the band),
        ``white``, ``independent`` (bool) and a one-line ``verdict``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> r = residual_analysis(rng.normal(size=5000), rng.normal(size=5000))
    >>> r["white"], r["independent"]
    (True, True)
    """
    e = np.asarray(residual, dtype=float)
    e = e[:, None] if e.ndim == 1 else e
    n = e.shape[0]
    if n <= 2 * max_lag + 1:
        raise InputError(
            f"residual_analysis needs more than {2 * max_lag + 1} samples for max_lag="
            f"{max_lag}; got {n}. Use a longer held-out record."
        )
    e = e - e.mean(axis=0)
    band = BAND_Z / np.sqrt(n)
    lags = np.arange(-max_lag, max_lag + 1)

    def xcorr(a, b):  # r_ab(k) = Σ a(t+k) b(t) / √(Σa² Σb²), k = −L..L (biased, as resid)
        # only the 2L+1 lags used, one dot product each: O(n·L) time, O(n) memory (the full
        # correlation, np.correlate(mode="full"), is O(n²): 8 s at 8e4 samples)
        seg = np.array(
            [float(a[k:] @ b[: n - k]) if k >= 0 else float(a[: n + k] @ b[-k:]) for k in lags]
        )
        den = np.sqrt(float(a @ a) * float(b @ b))
        return seg / den if den > 0 else np.full(seg.size, np.nan)

    auto = [xcorr(e[:, j], e[:, j])[max_lag:] for j in range(e.shape[1])]
    auto_out = [int(np.count_nonzero(np.abs(a[1:]) > band)) for a in auto]
    cross, cross_out = [], []
    if inputs is not None:
        u = np.asarray(inputs, dtype=float)
        u = u[:, None] if u.ndim == 1 else u
        u = u - u.mean(axis=0)
        for j in range(e.shape[1]):
            for k in range(u.shape[1]):
                c = xcorr(e[:, j], u[:, k])
                cross.append(c)
                cross_out.append(int(np.count_nonzero(np.abs(c) > band)))
    # With 25 (51) independent lags, a white residual leaves about 0.25 (0.5) of them outside the
    # 99 % band, so one lag outside is no evidence (26 % (40 %) chance). A test fails when 2 or
    # more lags are outside (chance 2.6 % (9 %)) or one is outside the Bonferroni band
    # z = Φ⁻¹(1 − 0.005 / n_lags) (family-wise 1 %).
    from scipy.stats import norm

    def fails(values, n_lags):
        strict = norm.ppf(1.0 - 0.005 / n_lags) / np.sqrt(n)
        v = np.abs(np.asarray(values))
        return int(np.count_nonzero(v > band)) >= 2 or bool(np.any(v > strict))

    white = not any(fails(a[1:], max_lag) for a in auto)
    independent = not any(fails(c, 2 * max_lag + 1) for c in cross)
    if white and independent:
        verdict = (
            "residual is white and uncorrelated with the input (99 % band): the model explains "
            "the data"
        )
    elif not independent:
        verdict = (
            "residual is correlated with the input (outside the 99 % band at "
            f"{max(cross_out)} lags): the model misses part of the input-output dynamics"
        )
    else:
        verdict = (
            f"residual is not white (autocorrelation outside the 99 % band at {max(auto_out)} "
            "lags): unmodelled dynamics or coloured noise; the input-output part may be fine"
        )
    return {
        "lags": lags,
        "band": float(band),
        "autocorrelation": auto,
        "cross_correlation": cross,
        "autocorrelation_outside": auto_out,
        "cross_correlation_outside": cross_out,
        "white": bool(white),
        "independent": bool(independent),
        "verdict": verdict,
    }


# --------------------------------------------------------------------------- result files
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
            from ..estimators._linear import predict_recording

            return predict_recording(self.model, self.coefficients, recording)
        from ..signals.recording import Recording

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
    from ..models import load_model

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


# --------------------------------------------------------------------------- the tests
@dataclass(frozen=True)
class ValidationReport:
    """Outcome of `validate`.

    Attributes
    ----------
    relative_error : dict
        Inverse-model cross-test: ``"overall"`` and one entry per force/torque channel
        (fractions).
    fit_percent : dict
        Output-error fit per output channel [%] (MATLAB ``compare``).
    output_relative_error : dict
        Output-error ``‖y − ŷ‖ / ‖y‖`` per output channel (fractions).
    residual : dict
        `residual_analysis` of the residual named in ``residual["of"]``.
    notes : tuple of str
        How each number was computed (filters, skipped tests and why).
    series : dict
        Arrays for the plots (`physid.report.validation.write_validation_plots`; not in ``to_dict``).
    """

    relative_error: dict[str, float]
    fit_percent: dict[str, float]
    output_relative_error: dict[str, float]
    residual: dict[str, Any]
    notes: tuple[str, ...] = ()
    series: dict[str, Any] = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (the ``physid validate --json`` object).

        Returns
        -------
        dict
            ``relative_error``, ``fit_percent``, ``output_relative_error``, ``residual``,
            ``notes``.
        """
        return jsonable(
            {
                "relative_error": self.relative_error,
                "fit_percent": self.fit_percent,
                "output_relative_error": self.output_relative_error,
                "residual": self.residual,
                "notes": list(self.notes),
            }
        )

    def summary(self) -> str:
        """Human-readable lines: the three tests and the verdict.

        Returns
        -------
        str
        """
        lines = ["validation on held-out data"]
        if self.relative_error:
            parts = ", ".join(f"{k} {v:.4g}" for k, v in self.relative_error.items())
            lines.append(f"  (a) inverse model, relative error: {parts}")
        for k, v in self.fit_percent.items():
            rel = self.output_relative_error.get(k, float("nan"))
            lines.append(f"  (b) output error {k}: fit {v:.2f} %, relative error {rel:.4g}")
        if self.residual:
            lines.append(f"  (c) {self.residual.get('verdict', '')}")
        lines.extend(f"  note: {n}" for n in self.notes)
        return "\n".join(lines)


def _linear_inverse(loaded, recording):
    """Inverse-model test of a linear ODE: û from the filtered output (and input derivatives)."""
    from ..estimators.recursive import (
        default_prefilter_cutoff,
        state_variable_filter,
        svf_transient_samples,
    )

    model = loaded.model
    values = loaded.coefficients
    in_name, out_name = model.recording_channels(recording.names)
    dt = recording.dt
    cutoff = (loaded.data.get("prefilter_cutoff") if loaded.method == "rls" else None) or None
    note = (
        f"the state-variable filter of the fit ({cutoff:g} Hz)"
        if cutoff
        else "the state-variable filter at the RLS default cut-off (the algebraic estimator "
        "does not filter)"
    )
    if not cutoff:
        from ..estimators.recursive import _model_frequency

        cutoff = default_prefilter_cutoff(dt, _model_frequency(model))
    n, m = model.order, model.input_order
    highest = max(n, m)
    order = highest + 1
    # the measured output is y + offset (the model's output_offset, as the prediction of (b)
    # adds it): the derivatives of the constant vanish, but a0·y would see it
    offset = getattr(model, "output_offset", None)
    held = bool(offset) and offset not in values  # identify = false: the model's value
    o = float(values[offset]) if offset in values else model.known_output_offset()
    y_m = np.asarray(recording[out_name], dtype=float) - o
    derivs = state_variable_filter(
        np.column_stack([y_m, recording[in_name]]), dt, cutoff, highest, order
    )
    skip = min(svf_transient_samples(cutoff, dt, order), derivs.shape[0] // 2)
    yd, ud = derivs[skip:, 0, :], derivs[skip:, 1, :]
    # Σ a_i y^(i) (a_n = 1) = Σ b_j u^(j)  ⇒  û_f = (Σ a_i y_f^(i) − Σ_{j≥1} b_j u_f^(j)) / b_0
    lhs = yd[:, n].copy()
    for i, name in enumerate(model.a_names):
        lhs += values[name] * yd[:, i]
    for j, name in enumerate(model.b_names[1:], start=1):
        lhs -= values[name] * ud[:, j]
    b0 = values[model.b_names[0]]
    u_hat = lhs / b0 if b0 != 0 else np.full(lhs.shape, np.nan)
    u_f = ud[:, 0]
    t = np.asarray(recording.t)[skip:]
    note = f"inverse model on {note}; first {skip} samples dropped"
    if offset:
        kind = "held" if held else "estimated"
        note += f"; the {kind} output offset {offset} = {o:.6g} subtracted from the output"
    return in_name, t, u_f, u_hat, note


def _is_idim(loaded) -> bool:
    return str(loaded.method).startswith("idim")


def _idim_threshold(loaded) -> tuple[float, bool]:
    """The fit's ``stick_threshold`` and whether the result records it (else the default)."""
    from ..estimators._stiction import STICK_THRESHOLD

    value = loaded.data.get("stick_threshold")
    if value is None:
        return STICK_THRESHOLD, False
    return float(value), True


def _idim_inverse(loaded, recording):
    """(t, τ_f, τ̂, stuck) of an IDIM result: the fit's rows, its near-rest equations dropped.

    The rows are built with the fit's filter settings and ``stick_threshold`` (`idim_rows`), so
    a Coulomb joint's equations near rest are zero on both sides, as in the fit, and the
    relative error is the fit's on the fit's own record. ``stuck`` (rows × joints, bool) is
    None when nothing is dropped.
    """
    from ..estimators.idim import base_regressor_info, idim_rows

    d = loaded.data
    model = loaded.model
    info = base_regressor_info(model)
    names = tuple(d.get("names") or loaded.parameters)
    missing = [n for n in names if n not in loaded.parameters]
    if missing:
        raise InputError(f"the result file lacks the value(s) of {missing}.")
    beta = np.array([loaded.parameters[n] for n in names], dtype=float)
    if names == info.independent:  # files written before wave 3 keyed the kept columns
        names = info.names
    if names != info.names:
        raise InputError(
            f"the result has {len(names)} base parameters ({list(names)[:4]}…), but the model "
            f"{getattr(model, 'name', '')!r} has {info.n_base} ({list(info.names)[:4]}…); "
            f"validate with the model the result was fitted with "
            f"({arg('model', '...', cli='MODEL')})."
        )
    threshold, _ = _idim_threshold(loaded)
    rows = idim_rows(
        model,
        recording,
        info=info,
        differentiation=d.get("differentiation", "physid"),
        cutoff=d.get("cutoff", "auto"),
        half_width=d.get("half_width"),
        decimate=d.get("decimate", "auto"),
        stick_threshold=threshold,
    )
    return np.asarray(rows.t), np.asarray(rows.tau), rows.W @ beta, rows.stuck


def _chain_inverse(loaded, recording):
    """(t, τ_f, τ̂) of a chain result on the held-out recording, filtered as in the fit."""
    from ..estimators.input_error import InputErrorEstimator

    d = loaded.data
    if _is_idim(loaded):
        # IDIM estimates base parameters: τ̂ = W_base β̂ on rows filtered and decimated with the
        # fit's own settings (the robotics convention for the cross-test), by the same function
        # as IDIMResult.predict
        from ..estimators.idim import predict_torque

        names = list(d.get("names") or loaded.parameters)
        missing = [n for n in names if n not in loaded.parameters]
        if missing:
            raise InputError(f"the result file lacks the value(s) of {missing}.")
        pred = predict_torque(
            loaded.model,
            names,
            [loaded.parameters[n] for n in names],
            recording,
            differentiation=d.get("differentiation", "physid"),
            cutoff=d.get("cutoff", "auto"),
            half_width=d.get("half_width"),
            decimate=d.get("decimate", "auto"),
            measured=True,
        )
        nj = int(loaded.model.n_joints)
        tau_hat = pred.select([f"tau{j + 1}" for j in range(nj)])
        tau_f = pred.select([f"tau{j + 1}_measured" for j in range(nj)])
        return np.asarray(pred.t), tau_f, tau_hat
    settings = {
        k: d[k] for k in ("half_width", "cutoff", "torque", "derivatives") if d.get(k) is not None
    }
    if settings.get("torque") == "pd":  # the gains the fit was given, else the record's metadata
        gains = d.get("gains") or {}
        settings.update({k: gains[k] for k in ("kp", "kd") if gains.get(k) is not None})
    est = InputErrorEstimator(loaded.model, **settings)
    t, qf, qdf, qddf, tau_f = est.filtered_signals(recording)[:5]
    params = _input_error_parameters(loaded)
    tau_hat = np.asarray(loaded.model.inverse_dynamics(qf, qdf, qddf, params), dtype=float)
    return t, tau_f, tau_hat


def _idim_parameters(loaded) -> dict[str, float]:
    """Standard parameters of an IDIM result's fitted base model: each base value on its kept
    column (``columns``), 0 on every other column (``τ = Y θ = W_b β``)."""
    from ..estimators.idim import base_regressor_info

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
    `InputErrorResult.model_parameters`). Files written before base names (wave 3) keyed the
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


def validate(result, recording, *, model=None, max_lag: int = MAX_LAG) -> ValidationReport:
    """Validate an identified model on held-out data: tests (a), (b), (c) of the module docstring.

    Parameters
    ----------
    result : LoadedResult, fitted result object, or path to a result file
        The identified model.
    recording : Recording
        Held-out data with the channels and sample period the fit used.
    model : str or model, optional
        The model, where the result file does not name it.
    max_lag : int
        Lags of the residual tests.

    Returns
    -------
    ValidationReport

    Raises
    ------
    InputError
        The held-out recording lacks a channel of the model or has another sample period.
    """
    loaded = _as_loaded(result, model)
    notes: list[str] = []
    for note in (_check_sampling(loaded, recording), _options_note(loaded)):
        if note:
            notes.append(note)
    series: dict[str, Any] = {}
    rel: dict[str, float] = {}
    fits: dict[str, float] = {}
    out_rel: dict[str, float] = {}
    residual: dict[str, Any] = {}
    if loaded.is_linear:
        in_name, t_f, u_f, u_hat, note = _linear_inverse(loaded, recording)
        rel = {"overall": _relative(u_hat - u_f, u_f), in_name: _relative(u_hat - u_f, u_f)}
        notes.append(f"(a) {note}")
        series["inverse"] = (t_f, {in_name: (u_f, u_hat)})
        pred = loaded.predict(recording)
        out_name = pred.names[1]
        y = np.asarray(recording[out_name], dtype=float)
        y_hat = np.asarray(pred[out_name], dtype=float)
        fits[out_name] = fit_percent(y, y_hat)
        out_rel[out_name] = _relative(y - y_hat, y)
        notes.append(
            "(b) open-loop simulation on the held-out input, initial state fitted by least squares"
        )
        series["output"] = (np.asarray(recording.t), {out_name: (y, y_hat)})
        if not np.all(np.isfinite(y_hat)):
            notes.append("(c) skipped: the identified model cannot be simulated (unstable)")
        elif _enough_for_residual(y.size, max_lag, "samples", notes):
            residual = residual_analysis(y - y_hat, recording[in_name], max_lag=max_lag)
            residual["of"] = f"output error of {out_name}"
    else:
        stuck = None
        if _is_idim(loaded):
            t_f, tau_f, tau_hat, stuck = _idim_inverse(loaded, recording)
        else:
            t_f, tau_f, tau_hat = _chain_inverse(loaded, recording)
        names = [f"tau{j + 1}" for j in range(tau_f.shape[1])]
        rel = {"overall": _relative(tau_hat - tau_f, tau_f)}
        rel.update(
            {nm: _relative(tau_hat[:, j] - tau_f[:, j], tau_f[:, j]) for j, nm in enumerate(names)}
        )
        notes.append(
            "(a) inverse model on the filtered signals of the fit (half_width "
            f"{loaded.data.get('half_width')}, cutoff {loaded.data.get('cutoff')} rad/sample), "
            "valid samples only"
        )
        if _is_idim(loaded):
            notes.append(_stick_note(loaded, stuck))
        if stuck is not None:  # plots and (c): the rows where every joint's equation is kept
            free = ~np.any(stuck, axis=1)
            if free.all():
                pass
            elif free.sum() > 2 * max_lag + 1:
                t_f, tau_f, tau_hat = t_f[free], tau_f[free], tau_hat[free]
                notes.append(
                    "(c) runs on the kept rows joined end to end: its lags span the gaps "
                    "where rows near rest were dropped"
                )
            else:  # too few rows with every joint moving (a 6-DOF arm): keep every row
                notes.append(
                    "(c) runs on every row, the dropped equations counting as zero residual: "
                    f"only {int(free.sum())} rows have every joint's equation kept"
                )
        series["inverse"] = (t_f, {nm: (tau_f[:, j], tau_hat[:, j]) for j, nm in enumerate(names)})
        fits, out_rel, note = _chain_output_error(loaded, recording, series)
        notes.append(note)
        what = "filtered, decimated rows" if _is_idim(loaded) else "filtered samples"
        if _enough_for_residual(tau_f.shape[0], max_lag, what, notes):
            residual = residual_analysis(tau_hat - tau_f, max_lag=max_lag)
            residual["of"] = "inverse-model torque error (filtered)"
    if residual:
        series["residual"] = residual
    return ValidationReport(rel, fits, out_rel, residual, tuple(notes), series)


def _stick_note(loaded, stuck) -> str:
    """What (a) and (c) dropped near rest, with the fit's ``stick_threshold``."""
    threshold, recorded = _idim_threshold(loaded)
    source = (
        "the fit's"
        if recorded
        else "the IDIM default (the result does not record the fit's; written by an older physid)"
    )
    if stuck is None or not stuck.any():
        return (
            f"(a) stiction rule (threshold {threshold:g}·rms of the speed, {source}): "
            "no joint equation dropped near rest"
        )
    free = int(np.count_nonzero(~np.any(stuck, axis=1)))
    return (
        f"(a) {int(stuck.sum())} of {stuck.size} joint equations dropped near rest, as in the "
        f"fit: Coulomb joints at |q̇| < {threshold:g}·rms (stiction threshold: {source}), "
        "where stiction makes the friction torque unknown; (c) uses the "
        f"{free} rows where no equation is dropped"
    )


def _chain_output_error(loaded, recording, series):
    """Closed-loop re-simulation with the recording's PD controller (needs kp, kd and r)."""
    meta = dict(getattr(recording, "metadata", {}) or {})
    model = loaded.model
    nj = int(model.n_joints)
    r_names = [f"r{j + 1}" for j in range(nj)]
    q_names = [f"q{j + 1}" for j in range(nj)]
    if "kp" not in meta or "kd" not in meta or not all(n in recording.names for n in r_names):
        return (
            {},
            {},
            (
                "(b) skipped: closed-loop re-simulation needs the controller gains kp, kd in the "
                "recording's metadata and the reference channels r1..rn"
            ),
        )
    from ..simulate.closed_loop import simulate_closed_loop

    what = "closed-loop simulation"
    if _is_idim(loaded):
        # The consistent estimate's standard parameters (in ``derived``) where there are; else the
        # fitted base model: each base value on its kept column and 0 on the others gives
        # τ = Y θ = W_b β exactly (every dependent column is regrouped into its base parameter),
        # as `InputErrorResult.model_parameters` does.
        standard = {k: v for k, v in loaded.derived.items() if k in model.parameter_names}
        if standard:
            params = standard
            what += " of the consistent estimate's standard parameters"
        else:
            params = _idim_parameters(loaded)
            what += (
                " of the fitted base model (each base parameter on its kept column, the others "
                "0: it gives the fitted torques, but it is not a physical parameter set)"
            )
    else:
        params = _input_error_parameters(loaded)
    params = {k: v for k, v in params.items() if k in model.parameter_names}
    t = np.asarray(recording.t, dtype=float)
    reference = np.column_stack([recording[n] for n in r_names])
    q0 = np.array([recording[n][0] for n in q_names])
    try:
        sim = simulate_closed_loop(
            model,
            kp=meta["kp"],
            kd=meta["kd"],
            reference=reference,
            t=t,
            q0=q0,
            params=params,
        )
    except Exception as exc:  # a diverging identified model: report, do not crash
        return {}, {}, f"(b) closed-loop re-simulation failed: {exc}"
    if not all(np.all(np.isfinite(np.asarray(sim[n], dtype=float))) for n in q_names):
        return {}, {}, f"(b) {what} diverged (the identified model cannot be simulated)"
    fits, rel, data = {}, {}, {}
    for n in q_names:
        y, y_hat = np.asarray(recording[n]), np.asarray(sim[n])
        fits[n] = fit_percent(y, y_hat)
        rel[n] = _relative(y - y_hat, y)
        data[n] = (y, y_hat)
    series["output"] = (t, data)
    return fits, rel, f"(b) {what} with the recording's kp, kd and reference"


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
        from ..models import load_model

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


def _options_note(loaded: LoadedResult) -> str | None:
    """Say what `validate` assumed where the file does not record how the fit was set up."""
    d = loaded.data
    if loaded.is_linear or "model" not in d:  # a result object, or a linear ODE (all coefficients)
        return None
    parts = []
    if loaded.model_options is None and "model_options" not in d:
        kinetic = getattr(loaded.model, "kinetic", None)
        parts.append(
            "the result file does not record the options the model was loaded with (written by "
            f"an older physid): it was loaded with its defaults (kinetic {kinetic!r}); if the fit "
            "used others, refit and save again"
        )
    if d.get("torque") == "pd" and not d.get("gains"):
        parts.append(
            "the PD torque is rebuilt with the gains in the held-out record's metadata (the file "
            "records no gains given to the fit)"
        )
    return "model: " + "; ".join(parts) if parts else None


def _enough_for_residual(n: int, max_lag: int, what: str, notes: list[str]) -> bool:
    """Whether (c) can run on ``n`` rows; if not, a note says why it was skipped (not an error:
    (a) and (b) stand on their own)."""
    if n > 2 * max_lag + 1:
        return True
    notes.append(
        f"(c) skipped: the residual tests at ±{max_lag} lags need more than {2 * max_lag + 1} "
        f"{what}; the held-out record gives {n}. Use a longer held-out record for (c)."
    )
    return False


def _check_sampling(loaded: LoadedResult, recording) -> str | None:
    """Refuse a held-out record at another sample period; a note when the file has no period.

    The fit's filters are defined per sample (cut-off in rad/sample, half-width and decimation
    in samples), so on another period they are other filters in Hz.
    """
    fit_dt = (loaded.data.get("settings") or {}).get("dt", loaded.data.get("dt"))
    if fit_dt is not None and not np.isfinite(float(fit_dt)):
        fit_dt = None
    if fit_dt is None:
        if loaded.is_linear:
            return None  # linear-ODE results filter in Hz from the held-out record's own dt
        cutoff = loaded.data.get("cutoff")
        hz = ""
        if isinstance(cutoff, (int, float)) and np.isfinite(cutoff):
            in_hz = float(cutoff) / (2 * np.pi * recording.dt)
            hz = f" (its cut-off {float(cutoff):.4g} rad/sample is {in_hz:.4g} Hz at this period)"
        return (
            "sampling: the result file does not record the fit's sample period (written by an "
            f"older physid), so it cannot be checked; the held-out record ({recording.dt:g} s) "
            f"is assumed to be sampled as the fit was{hz}. Refit to record it."
        )
    dt = recording.dt
    if not np.isclose(dt, float(fit_dt), rtol=1e-6, atol=0):
        raise InputError(
            f"the held-out recording is sampled every {dt:g} s but the fit used {float(fit_dt):g} s; "
            "resample it to the fit's period (Recording.resample), or refit."
        )
    return None
