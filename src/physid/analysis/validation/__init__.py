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
    loop for chains with the controller that ran: PD gains ``kp``, ``kd`` given, saved in the
    result file or in the recording's metadata, the recording's feed-forward and reference ``r``; an
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
`physid.estimators.results.save_result`); `validate` runs the three tests. Each test has its
module: (a) `inverse`, (b) `output_error`, (c) `residual`; result files are read in `loaded`
and their parameters in `parameters`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import DataFileError as DataFileError
from ...errors import InputError
from ...errors import arg as arg
from ...estimators.results import RESULT_FORMAT as RESULT_FORMAT
from ...estimators.results import jsonable
from .inverse import _chain_inverse as _chain_inverse
from .inverse import (
    _idim_inverse,
    _idim_rows,
    _linear_inverse,
    _position_noise_draws,
    _rowless_joints,
    _stick_note,
)
from .inverse_residual import explain_inverse_residual, set_aside_reversals
from .loaded import LoadedResult, _as_loaded, load_result
from .output_error import _chain_output_error, _relative, check_controller, fit_percent
from .parameters import _base_theta as _base_theta
from .parameters import _idim_parameters as _idim_parameters
from .parameters import _idim_threshold as _idim_threshold
from .parameters import _input_error_parameters as _input_error_parameters
from .parameters import _is_idim
from .residual import (
    BAND_Z,
    MAX_LAG,
    _enough_for_residual,
    explain_residual,
    residual_analysis,
)

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

_LINEAR_METHODS = ("algebraic", "rls")


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
    failures : tuple of str
        What makes the fit fail on this record although numbers could be computed (an IDIM
        joint whose every equation was dropped: no rows to test it on).
    series : dict
        Arrays for the plots (`physid.report.validation.write_validation_plots`; not in ``to_dict``).
    """

    relative_error: dict[str, float]
    fit_percent: dict[str, float]
    output_relative_error: dict[str, float]
    residual: dict[str, Any]
    notes: tuple[str, ...] = ()
    series: dict[str, Any] = field(default_factory=dict, repr=False)
    failures: tuple[str, ...] = ()

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
                "failures": list(self.failures),
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
        lines.extend(f"  FAILED: {f}" for f in self.failures)
        lines.extend(f"  note: {n}" for n in self.notes)
        return "\n".join(lines)


def validate(
    result, recording, *, model=None, max_lag: int = MAX_LAG, kp=None, kd=None, feedforward=None
) -> ValidationReport:
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
    kp, kd : array_like (n_joints,), optional
        Chains: the PD gains [N·m/rad], [N·m·s/rad] of test (b)'s closed-loop re-simulation;
        default: the gains saved in the result file, else the recording's metadata. The note of
        (b) says which gains were used and where they came from.
    feedforward : {None, "none", "gravity", "gravity+friction"}
        Chains: the feed-forward added to the PD law in (b); default: the one the fit was given
        (saved in the result file), else the recording's metadata.

    Returns
    -------
    ValidationReport

    Raises
    ------
    InputError
        The held-out recording lacks a channel of the model or has another sample period; a
        gain that is negative or not one per joint, an unknown feed-forward, or a controller
        given for a linear ODE (which is simulated in open loop).
    """
    loaded = _as_loaded(result, model)
    given = {"kp": kp, "kd": kd, "feedforward": feedforward}
    if loaded.is_linear and any(v is not None for v in given.values()):
        named = ", ".join(arg(k) for k, v in given.items() if v is not None)
        raise InputError(
            f"{named}: a linear ODE's output-error test is an open-loop simulation on the "
            "recorded input, with no controller; leave them out."
        )
    controller = None if loaded.is_linear else check_controller(loaded.model.n_joints, **given)
    notes: list[str] = []
    for note in (_check_sampling(loaded, recording), _options_note(loaded)):
        if note:
            notes.append(note)
    series: dict[str, Any] = {}
    if loaded.is_linear:
        rel, fits, out_rel, residual = _validate_linear(loaded, recording, max_lag, notes, series)
    else:
        rel, fits, out_rel, residual = _validate_chain(
            loaded, recording, max_lag, notes, series, controller
        )
    if residual:
        series["residual"] = residual
    failures = tuple(series.pop("failures", ()))
    return ValidationReport(rel, fits, out_rel, residual, tuple(notes), series, failures)


def _validate_linear(loaded, recording, max_lag, notes, series):
    """Tests (a), (b), (c) of a linear ODE; (c) on the output error of (b)."""
    fits: dict[str, float] = {}
    out_rel: dict[str, float] = {}
    residual: dict[str, Any] = {}
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
        impulse = _impulse_response(loaded, recording.t)
        explain_residual(residual, y - y_hat, y, impulse, inputs=recording[in_name])
    return rel, fits, out_rel, residual


def _impulse_response(loaded, t):
    """The identified model's response to one unit input sample (offset removed).

    The pulse sits at sample 1, not 0: an interpolated input spreads an interior sample over
    the intervals on both sides, as it does each sample of the noise.
    """
    from ...estimators._linear import simulate_prediction

    pulse = np.zeros(np.asarray(t).size)
    pulse[1] = 1.0
    g, _ = simulate_prediction(loaded.model, loaded.coefficients, t, pulse)
    rest, _ = simulate_prediction(loaded.model, loaded.coefficients, t, np.zeros_like(pulse))
    return np.append((g - rest)[1:], 0.0)


def _validate_chain(loaded, recording, max_lag, notes, series, controller=None):
    """Tests (a), (b), (c) of a chain; (c) on the inverse-model error of (a)."""
    residual: dict[str, Any] = {}
    stuck = rows = None
    if _is_idim(loaded):
        t_f, tau_f, tau_hat, stuck, rows = _idim_inverse(loaded, recording)
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
        notes.append(_stick_note(loaded, stuck, rows.reversal))
        series["failures"] = _rowless_joints(stuck, names)
    # the plots show every row, a dropped equation as a gap (NaN), never as a torque of 0 N·m
    shown_f, shown_hat = np.array(tau_f, dtype=float), np.array(tau_hat, dtype=float)
    if stuck is not None and np.any(stuck):
        shown_f[stuck], shown_hat[stuck] = np.nan, np.nan
    series["inverse"] = (t_f, {nm: (shown_f[:, j], shown_hat[:, j]) for j, nm in enumerate(names)})
    if rows is not None and loaded.data.get("reversal_joints"):
        # (c) judges the record's equations, not the fit's choice: the equations the fit
        # dropped only because its residual stood out (next to reversals, at low speed) are
        # tested with the others; those of a stuck joint stay out (no torque to explain)
        t_f, tau_f, tau_hat, stuck, reversal = _sticking_rows(loaded, recording)
    else:
        reversal = None
    index = np.arange(tau_f.shape[0])  # (c)'s rows in the decimated sequence
    kept = np.ones(tau_f.shape, dtype=bool) if stuck is None else ~stuck
    if stuck is not None:  # (c): the rows where every joint's equation is kept
        free = ~np.any(stuck, axis=1)
        if free.all():
            pass
        elif free.sum() > 2 * max_lag + 1:
            t_f, tau_f, tau_hat = t_f[free], tau_f[free], tau_hat[free]
            index, kept = index[free], kept[free]
            reversal = None if reversal is None else reversal[free]
            notes.append(
                "(c) runs on the kept rows joined end to end: its lags span the gaps "
                "where rows near rest were dropped"
            )
        else:  # too few rows with every joint moving (a 6-DOF arm): keep every row
            notes.append(
                "(c) runs on every row, the dropped equations counting as zero residual: "
                f"only {int(free.sum())} rows have every joint's equation kept"
            )
    fits, out_rel, note = _chain_output_error(loaded, recording, series, controller)
    notes.append(note)
    what = "filtered, decimated rows" if _is_idim(loaded) else "filtered samples"
    if _enough_for_residual(tau_f.shape[0], max_lag, what, notes):
        error = tau_hat - tau_f
        residual = residual_analysis(error, max_lag=max_lag)
        residual["of"] = "inverse-model torque error (filtered)"
        if rows is not None:  # IDIM: against the filters' colouring, position noise, the model
            where = {"nd": rows.decimate, "index": index, "kept": kept}
            draws = _position_noise_draws(loaded, recording, rows, index, kept)
            explain_inverse_residual(residual, error, tau_f, position_noise=draws, **where)
            if residual["explanation"] == "model" and reversal is not None:
                residual = set_aside_reversals(
                    residual,
                    error,
                    tau_f,
                    reversal=reversal,
                    position_noise=lambda k: _position_noise_draws(
                        loaded, recording, rows, index, k
                    ),
                    **where,
                )
    return rel, fits, out_rel, residual


def _sticking_rows(loaded, recording):
    """(t, τ_f, τ̂, stuck, reversal) of an IDIM result with only the sticking equations dropped;
    ``reversal`` marks the equations next to speed reversals of the joints whose reversal
    equations the fit dropped (``reversal_joints``), or is None."""
    threshold, _ = _idim_threshold(loaded)
    rows, beta = _idim_rows(loaded, recording, stick_threshold=threshold)
    reversal = None
    if rows.reversal is not None:
        reversal = np.zeros(rows.reversal.shape, dtype=bool)
        joints = [int(j) - 1 for j in loaded.data.get("reversal_joints") or ()]
        reversal[:, joints] = rows.reversal[:, joints]
    return np.asarray(rows.t), np.asarray(rows.tau), rows.W @ beta, rows.stuck, reversal


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
