"""Test (b) of `physid.analysis.validation`: the output error, MATLAB ``compare``'s fit and the
relative error; for chains the closed-loop re-simulation with the recording's PD controller (a
linear ODE's open-loop simulation is `LoadedResult.predict`). The controller: PD gains given,
saved in the result file or in the recording's metadata, plus the recording's feed-forward."""

from __future__ import annotations

import numpy as np

from .parameters import _idim_parameters, _input_error_parameters, _is_idim

__all__ = ["check_controller", "fit_percent"]


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


def check_controller(nj: int, kp=None, kd=None, feedforward=None) -> dict:
    """Check the controller given to `validate`: ``{"kp": (nj,), "kd": (nj,), "feedforward"}``.

    Parameters
    ----------
    nj : int
        Number of joints.
    kp, kd : array_like (nj,), optional
        PD gains [N·m/rad], [N·m·s/rad], one per joint (or one for all), each >= 0.
    feedforward : {None, "none", "gravity", "gravity+friction"}

    Returns
    -------
    dict
        Only the keys given.

    Raises
    ------
    InputError, ShapeError
        A gain that is not a number, negative, or not one per joint; an unknown feed-forward.
    """
    from ..._validate import per_joint
    from ...errors import InputError, arg
    from ...simulate.feedforward import FEEDFORWARD

    out: dict = {}
    for name, value in (("kp", kp), ("kd", kd)):
        if value is None:
            continue
        gains = per_joint(value, name, nj)
        if np.any(gains < 0):
            raise InputError(
                f"{arg(name)} must be gains >= 0, one per joint ({nj}); got "
                f"{gains.tolist()!r}. A negative gain destabilises the loop: check the sign."
            )
        out[name] = gains
    if feedforward is not None:
        if not isinstance(feedforward, str) or feedforward not in FEEDFORWARD:
            raise InputError(
                f"{arg('feedforward')} must be one of {sorted(FEEDFORWARD)}; got {feedforward!r}."
            )
        out["feedforward"] = str(feedforward)
    return out


def _controller_of(loaded, meta, given: dict):
    """The gains and feed-forward to simulate, each with where it came from.

    Gains: given (``kp=``/``kd=``, the command line's ``--kp/--kd``), else the fit's saved gains
    (``gains`` of the result file: identify's ``--kp/--kd``), else the held-out recording's
    metadata. Feed-forward: given, else the fit's (``feedforward`` of the result file: identify's
    ``--feedforward``), else the recording's metadata, else none.
    """
    saved = loaded.data.get("gains") or {}
    out, sources = {}, {}
    for name in ("kp", "kd"):
        if name in given:
            out[name], sources[name] = given[name], "given"
        elif saved.get(name) is not None:
            out[name], sources[name] = saved[name], "the result file"
        elif meta.get(name) is not None:
            out[name], sources[name] = meta[name], "the held-out recording's metadata"
    if "feedforward" in given:
        ff, sources["feedforward"] = given["feedforward"], "given"
    elif loaded.data.get("feedforward") is not None:
        ff, sources["feedforward"] = str(loaded.data["feedforward"]), "the result file"
    elif meta.get("feedforward") is not None:
        ff, sources["feedforward"] = str(meta["feedforward"]), "the recording's metadata"
    else:
        ff, sources["feedforward"] = "none", "none recorded"
    return out, ff, sources


def _describe(kp, kd, law: str, sources: dict) -> str:
    """``controller tau = … with kp [...] (from …), kd [...] (from …)``."""

    def fmt(v):
        return "[" + ", ".join(f"{float(x):.4g}" for x in np.ravel(v)) + "]"

    return (
        f"controller {law} with kp {fmt(kp)} (from {sources['kp']}), kd {fmt(kd)} (from "
        f"{sources['kd']}), feed-forward from {sources['feedforward']}"
    )


def _chain_output_error(loaded, recording, series, given=None):
    """Closed-loop re-simulation with the controller that ran (needs kp, kd and r).

    ``given``: the controller passed to `validate` (`check_controller`'s dict).
    """
    meta = dict(getattr(recording, "metadata", {}) or {})
    model = loaded.model
    nj = int(model.n_joints)
    r_names = [f"r{j + 1}" for j in range(nj)]
    q_names = [f"q{j + 1}" for j in range(nj)]
    gains, feedforward, sources = _controller_of(loaded, meta, dict(given or {}))
    if "kp" not in gains or "kd" not in gains or not all(n in recording.names for n in r_names):
        return (
            {},
            {},
            (
                "(b) skipped: closed-loop re-simulation needs the controller gains kp, kd (given, "
                "in the result file or in the recording's metadata) and the reference channels "
                "r1..rn"
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
            kp=gains["kp"],
            kd=gains["kd"],
            reference=reference,
            t=t,
            q0=q0,
            params=params,
            feedforward=feedforward,  # the log's controller
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
    law = sim.metadata.get("controller", "tau = Kp (r - q) - Kd qd")
    return (
        fits,
        rel,
        f"(b) {what} with the recording's reference; {_describe(gains['kp'], gains['kd'], law, sources)}",
    )
