"""Test (a) of `physid.analysis.validation`: the inverse-model cross-test, the forces/torques the
model predicts from the held-out motion on the signals filtered as in the fit (linear ODE, IDIM,
input-error)."""

from __future__ import annotations

import numpy as np

from ...errors import InputError, arg
from .parameters import _idim_threshold, _input_error_parameters, _is_idim


def _linear_inverse(loaded, recording):
    """Inverse-model test of a linear ODE: û from the filtered output (and input derivatives)."""
    from ...estimators.recursive import (
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
        from ...estimators.recursive import _model_frequency

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


def _idim_inverse(loaded, recording):
    """(t, τ_f, τ̂, stuck, rows) of an IDIM result: the fit's rows, its near-rest equations
    dropped.

    The rows are built with the fit's filter settings and ``stick_threshold`` (`idim_rows`), so
    a Coulomb joint's equations near rest are zero on both sides, as in the fit, and the
    relative error is the fit's on the fit's own record. ``stuck`` (rows × joints, bool) is
    None when nothing is dropped; ``rows`` is the `IDIMRows` (its ``decimate`` for the residual
    test's filter colouring).
    """
    rows, beta = _idim_rows(loaded, recording)
    return np.asarray(rows.t), np.asarray(rows.tau), rows.W @ beta, rows.stuck, rows


def _idim_rows(loaded, recording, **settings):
    """The `IDIMRows` of an IDIM result on ``recording`` (the fit's settings, overridden by
    ``settings``: ``cutoff``, ``half_width``, ``decimate``, ``stick_threshold``) and its base
    parameter vector β."""
    from ...estimators.idim import base_regressor_info, idim_rows

    d = loaded.data
    model = loaded.model
    info = base_regressor_info(model)
    names = tuple(d.get("names") or loaded.parameters)
    missing = [n for n in names if n not in loaded.parameters]
    if missing:
        raise InputError(f"the result file lacks the value(s) of {missing}.")
    beta = np.array([loaded.parameters[n] for n in names], dtype=float)
    if names == info.independent:  # files from before base names keyed the kept columns
        names = info.names
    if names != info.names:
        raise InputError(
            f"the result has {len(names)} base parameters ({list(names)[:4]}…), but the model "
            f"{getattr(model, 'name', '')!r} has {info.n_base} ({list(info.names)[:4]}…); "
            f"validate with the model the result was fitted with "
            f"({arg('model', '...', cli='MODEL')})."
        )
    threshold, _ = _idim_threshold(loaded)
    chosen = {
        "cutoff": d.get("cutoff", "auto"),
        "half_width": d.get("half_width"),
        "decimate": d.get("decimate", "auto"),
        "stick_threshold": threshold,
    }
    chosen.update(settings)
    rows = idim_rows(
        model,
        recording,
        info=info,
        differentiation=d.get("differentiation", "physid"),
        **chosen,
    )
    joints = d.get("reversal_joints") or ()
    if "stick_threshold" in settings:  # a threshold given: the sticking masks alone (the
        joints = ()  # position-noise draws' rows, test (c)'s rows), no residual-driven drops
    if joints and rows.reversal is not None:  # the reversal equations the fit dropped
        from ...estimators.idim.estimator import _drop_reversals

        mask = np.zeros(rows.W.shape[1], dtype=bool)
        mask[[int(j) - 1 for j in joints]] = True
        rows = _drop_reversals(rows, mask)
    return rows, beta


def _chain_inverse(loaded, recording):
    """(t, τ_f, τ̂) of a chain result on the held-out recording, filtered as in the fit."""
    from ...estimators.input_error import InputErrorEstimator

    d = loaded.data
    if _is_idim(loaded):
        # IDIM estimates base parameters: τ̂ = W_base β̂ on rows filtered and decimated with the
        # fit's own settings (the robotics convention for the cross-test), by the same function
        # as IDIMResult.predict
        from ...estimators.idim import predict_torque

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


def _rowless_joints(stuck, names) -> list[str]:
    """Failures: the joints whose every equation the stiction rule dropped on this record.

    Such a joint has no rows, so (a) cannot say how the model predicts its torque; its entry is
    null and ``overall`` covers the other joints only. That is a failure of the fit, not a
    missing number.
    """
    if stuck is None or stuck.shape[0] == 0:
        return []
    return [
        f"{name}: every one of its {stuck.shape[0]} equations was dropped by the stiction rule, "
        "so the fit cannot be checked on this joint (its relative error is null, overall "
        "covers the other joints only); refit with stick_threshold=0, or record motion "
        "where the joint moves"
        for j, name in enumerate(names)
        if stuck[:, j].all()
    ]


def _stick_note(loaded, stuck, candidates=None) -> str:
    """What (a) and (c) dropped near rest, with the fit's ``stick_threshold``: the sticking
    equations and (among ``candidates``) those the fit's residual test dropped, counted apart."""
    threshold, recorded = _idim_threshold(loaded)
    rule = (
        "sticking shown by the measured position"
        if isinstance(threshold, str)
        else f"|q̇| < {threshold:g}·rms"
    )
    source = (
        "the fit's"
        if recorded
        else "the IDIM default (the result does not record the fit's; written by an older physid)"
    )
    if stuck is None or not stuck.any():
        return f"(a) stiction rule ({rule}, {source}): no joint equation dropped"
    by_residual = 0 if candidates is None else int(np.count_nonzero(stuck & candidates))
    sticking = int(stuck.sum()) - by_residual
    kinds = []
    if sticking:
        kinds.append(
            f"{sticking} of joints with dry friction where {rule} (stiction rule: {source}), "
            "where stiction makes the friction torque unknown"
        )
    if by_residual:
        joints = ", ".join(str(int(j)) for j in (loaded.data.get("reversal_joints") or ()))
        kinds.append(
            f"{by_residual} of joint(s) {joints} next to speed reversals or at low speed, where "
            "the fit's residual stood out ((c) tests those equations with the others)"
        )
    return (
        f"(a) {int(stuck.sum())} of {stuck.size} joint equations dropped, as in the fit: "
        + "; ".join(kinds)
    )


def _position_noise_draws(loaded, recording, rows, index, kept, draws: int = 8, seed: int = 0):
    """A callable for `explain_inverse_residual`: the torque residuals white noise on the
    measured positions, at the bound ``σ_b = std(Δ²q_m) / √6`` per joint, gives through the
    fit's rows (``(W(q_m + n) − W(q_m)) β`` on ``index``, zero where not ``kept``), and ``σ_b``.

    The rows are rebuilt with the fit's filters (the cut-off, half-width and ``nd`` of ``rows``)
    and no stiction rule, so that both sides have the same equations; seeded.
    """

    def run():
        import dataclasses

        nj = int(loaded.model.n_joints)
        names = list(recording.names)
        cols = [names.index(f"q{j + 1}") for j in range(nj)]
        data = np.array(recording.data, dtype=float)
        sigma = np.std(np.diff(data[:, cols], 2, axis=0), axis=0) / np.sqrt(6.0)
        same = {
            "cutoff": rows.cutoff,
            "half_width": rows.half_width,
            "decimate": rows.decimate,
            "stick_threshold": 0.0,
        }
        base, beta = _idim_rows(loaded, recording, **same)
        rng = np.random.default_rng(seed)
        out = []
        for _ in range(draws):
            noisy = data.copy()
            noisy[:, cols] += rng.normal(size=(data.shape[0], nj)) * sigma
            moved, _ = _idim_rows(loaded, dataclasses.replace(recording, data=noisy), **same)
            if moved.W.shape != base.W.shape:
                return [], sigma
            d = ((moved.W - base.W) @ beta)[index]
            out.append(np.where(kept, d, 0.0))
        return out, sigma

    return run
