"""Validation of an identified structure on a held-out recording: the fit [%] of every output
simulated from rest on the held-out forces, and the residual tests (MATLAB ``resid``) of each
output's error: its whiteness and its cross-correlation with every force, against the 99 % band.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .residual import MAX_LAG, explain_residual, residual_analysis

__all__ = ["validate_structure", "summary_lines"]


def validate_structure(result, recording, *, max_lag: int = MAX_LAG) -> dict[str, Any]:
    """Fit [%] and residual tests of each output of an identified structure.

    Parameters
    ----------
    result : StructureResult
        An equation-error or output-error result (with its model).
    recording : Recording
        Held-out record with the model's force [N] and output channels, starting at rest.
    max_lag : int
        Lags of the residual tests (``1..max_lag`` for the autocorrelation,
        ``−max_lag..max_lag`` for the cross-correlation with each force).

    Returns
    -------
    dict
        ``fit_percent`` (output -> fit [%]), ``residual`` (output -> the `residual_analysis` of
        ``y − ŷ`` against the forces, with ``explanation`` and ``verdict``), ``consistent``
        (every output's residual is white and uncorrelated with the forces, or explained by the
        simulation's resolution or by noise on the measured force), ``verdict`` (one line) and
        ``notes``.
    """
    model = result.model
    sim = result.predict(recording)
    forces = recording.select(model.input_names)
    fits = result.fit_to(recording)
    impulses = _impulses(result, recording) if len(model.input_names) == 1 else None
    residual: dict[str, Any] = {}
    for j, name in enumerate(model.output_names):
        y = np.asarray(recording[name], dtype=float)
        e = y - np.asarray(sim[name], dtype=float)
        res = residual_analysis(e, forces, max_lag=max_lag)
        res["of"] = f"output error of {name}"
        if res["autocorrelation"]:  # a finite, non-constant residual: say why a test fails
            impulse = impulses[:, j] if impulses is not None else np.zeros_like(y)
            inputs = forces[:, 0] if impulses is not None else None
            explain_residual(res, e, y, impulse, inputs=inputs)
        residual[name] = res
    ok = {k: _consistent(r) for k, r in residual.items()}
    if not all(ok.values()):
        _parameter_explanation(result, recording, sim, forces, residual, ok, max_lag, impulses)
    if all(ok.values()):
        verdict = "consistent: every output's residual is explained (99 % band)"
    else:
        bad = [k for k, v in ok.items() if not v]
        untestable = [k for k in bad if not residual[k]["autocorrelation"]]
        missed = any(not residual[k]["independent"] for k in bad)
        verdict = (
            f"not testable: the residual of {', '.join(untestable)} "
            f"({residual[untestable[0]]['verdict']})"
            if untestable
            else f"the model misses dynamics: the residual of {', '.join(bad)} is "
            + ("correlated with the force" if missed else "not white")
            + " beyond what noise explains"
        )
    notes = [
        "simulated from rest on the held-out inputs (forces and base motions, linear between samples)",
        f"residual tests at ±{max_lag} lags against the 99 % band, per output",
    ]
    if impulses is None:
        notes.append("several inputs: input noise is not tested as an explanation")
    return {
        "fit_percent": fits,
        "residual": residual,
        "consistent": all(ok.values()),
        "verdict": verdict,
        "notes": notes,
    }


def _consistent(res: dict) -> bool:
    """A residual test passed, or its failure is explained by resolution, input noise or the
    estimate's own uncertainty."""
    if res["white"] and res["independent"]:
        return True
    return res.get("explanation") in ("resolution", "input noise", "parameter uncertainty")


def _parameter_explanation(result, recording, sim, forces, residual, ok, max_lag, impulses):
    """Whether the estimate's own error, within its covariance, explains the failed tests.

    An estimate off by δθ leaves J δθ in every output's error (J = ∂ŷ/∂θ, by central
    differences), correlated with the force although the model is right: on a high-SNR record
    even an error inside the 95 % interval shows. δθ̂ is fitted to all outputs at once (each
    output scaled by its residual's spread) and removed; the failure is explained when what is
    left passes the tests (with the explanations of `explain_residual`, as a residual of the
    true parameters would) and δθ̂ is plausible: δθ̂ᵀ Σ⁻¹ δθ̂ ≤ χ²_p(0.99), Σ the result's
    covariance. Without a covariance nothing is explained this way.
    """
    from scipy.stats import chi2

    cov = getattr(result, "covariance", None)
    if cov is None:
        return
    names = list(result.names)
    cov = np.asarray(cov, dtype=float)
    base = {**result.known, **result.parameters}
    y_names = list(result.model.output_names)
    e = recording.select(y_names) - sim.select(y_names)
    scale = np.maximum(np.std(e, axis=0), 1e-300)
    from ...simulate.structure import structure_response

    def outputs(params):
        return structure_response(result.model, recording.t, forces, params)[1]

    cols = []
    for name in names:
        h = 1e-6 * max(abs(base[name]), 1e-12)
        diff = outputs({**base, name: base[name] + h}) - outputs({**base, name: base[name] - h})
        cols.append(diff / (2 * h) / scale)
    J = np.stack([c.ravel() for c in cols], axis=1)
    delta, *_ = np.linalg.lstsq(J, (e / scale).ravel(), rcond=None)
    d2 = float(delta @ np.linalg.solve(cov, delta))
    limit = float(chi2.ppf(0.99, len(names)))
    left = e - (J @ delta).reshape(e.shape) * scale
    for j, name in enumerate(y_names):
        res = residual[name]
        if ok[name] or not res["autocorrelation"]:  # passed, or untestable (NaN, constant)
            continue
        again = residual_analysis(left[:, j], forces, max_lag=max_lag)
        if again["autocorrelation"] and forces.shape[1] == 1:
            y = np.asarray(recording[name], dtype=float)
            explain_residual(again, left[:, j], y, impulses[:, j], inputs=forces[:, 0])
        res["evidence"]["parameter_error_mahalanobis2"] = d2
        res["evidence"]["parameter_error_limit"] = limit
        if _consistent(again) and d2 <= limit:
            res["explanation"] = "parameter uncertainty"
            res["verdict"] = (
                "consistent: the correlations are those of the estimate's own error (an error "
                f"δθ with δθᵀΣ⁻¹δθ = {d2:.3g} ≤ {limit:.3g}, the 99 % χ² bound, removes them); "
                "the model explains the data within its intervals"
            )
            ok[name] = True


def _impulses(result, recording) -> np.ndarray:
    """Each output's response to one unit force sample at sample 1 (from rest), (n, n_out)."""
    from ...simulate.structure import structure_response

    t = np.asarray(recording.t, dtype=float)
    params = {**result.known, **result.parameters}
    pulse = np.zeros((t.size, 1))
    pulse[1] = 1.0
    _, g = structure_response(result.model, t, pulse, params)
    _, rest = structure_response(result.model, t, np.zeros_like(pulse), params)
    return np.vstack([(g - rest)[1:], np.zeros((1, g.shape[1]))])


def summary_lines(report: dict) -> list[str]:
    """The text summary of `validate_structure`'s report.

    Parameters
    ----------
    report : dict
        From `validate_structure`.

    Returns
    -------
    list of str
        One line each: the fit [%] and the residual tests of every output, then the verdict.
    """
    lines = ["fit [%] per output (simulated from rest on the held-out forces):"]
    lines += [f"  {k}: {v:.2f}" for k, v in report["fit_percent"].items()]
    lines.append("residual tests per output (whiteness; cross-correlation with the forces):")
    for k, r in report["residual"].items():
        auto = max(r["autocorrelation_outside"], default=0)
        cross = max(r["cross_correlation_outside"], default=0)
        lines.append(
            f"  {k}: {'white' if r['white'] else 'not white'} ({auto} lags outside the "
            f"{r['band']:.3g} band), {'independent' if r['independent'] else 'correlated'} "
            f"({cross} lags outside): {r['verdict']}"
        )
    lines.append(f"verdict: {report['verdict']}")
    return lines
