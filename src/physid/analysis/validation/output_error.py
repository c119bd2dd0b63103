"""Test (b) of `physid.analysis.validation`: the output error, MATLAB ``compare``'s fit and the
relative error; for chains the closed-loop re-simulation with the recording's PD controller (a
linear ODE's open-loop simulation is `LoadedResult.predict`)."""

from __future__ import annotations

import numpy as np

from .parameters import _idim_parameters, _input_error_parameters, _is_idim

__all__ = ["fit_percent"]


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
    from ...simulate.closed_loop import simulate_closed_loop

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
            feedforward=str(meta.get("feedforward", "none")),  # the log's controller
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
    return (
        fits,
        rel,
        (
            f"(b) {what} with the recording's kp, kd and reference; controller "
            f"{sim.metadata.get('controller', 'tau = Kp (r - q) - Kd qd')}"
        ),
    )
