"""IDIM stage 8: predictions of the inverse model, ``τ̂ = W β`` on a recording's rows.

`predict_torque` runs a recording through the fit's own filters (`idim_rows`) and returns the
predicted torques as a `Recording`; `torque_recording` is the one output shape of every
inverse-model prediction (IDIM's and input-error's).
"""

from __future__ import annotations

import numpy as np

from ...errors import InputError
from .base_parameters import base_regressor_info
from .rows import idim_rows

__all__ = ["predict_torque", "torque_recording"]


def predict_torque(
    model,
    names,
    beta,
    recording,
    *,
    differentiation: str = "physid",
    cutoff: float | str = "auto",
    half_width: int | None = None,
    decimate: int | str = "auto",
    measured: bool = False,
):
    """τ̂ = W β on a recording's rows, filtered and decimated as `idim_rows` builds them.

    Parameters
    ----------
    model : ChainModel
        The model the base parameters belong to.
    names : sequence of str
        Base-parameter names (``IDIMResult.names``); must be the model's base set.
    beta : array_like, shape (p,)
        Base-parameter values in the order of ``names``.
    recording : Recording
        ``t`` [s], ``q1..qn`` [rad | m] (``tau1..taun`` [N·m | N] with ``measured=True``).
    differentiation, cutoff, half_width, decimate :
        The fit's filter settings (see `idim_rows`; ``IDIMResult`` records them).
    measured : bool
        Also return the recording's torques through the same filter and decimation
        (channels ``tau1_measured..``).

    Returns
    -------
    Recording
        ``tau1..taun`` predicted at the kept rows (time ``t`` of those rows), optionally
        followed by ``tau1_measured..``; ``metadata["prediction"]`` says what was computed.
        Peak memory: one float64 copy of the base regressor (n_samples × n_joints × p).

    Raises
    ------
    InputError
        ``names`` is not the model's base set, or ``beta`` has another length; the recording
        lacks a channel.
    """
    from ...signals.recording import Recording

    if not isinstance(recording, Recording):
        raise InputError(
            f"recording must be one Recording; got {type(recording).__name__}. Predict each "
            "recording on its own."
        )
    info = base_regressor_info(model)
    names = tuple(names)
    beta = np.asarray(beta, dtype=float).ravel()
    if names == info.independent:  # older result files keyed the kept columns
        names = info.names
    if names != info.names or beta.size != len(names):
        raise InputError(
            f"the result has {len(names)} base parameters ({list(names)[:4]}…) and {beta.size} "
            f"values, but the model {getattr(model, 'name', '')!r} has {info.n_base} "
            f"({list(info.names)[:4]}…); predict with the model the result was fitted with."
        )
    nj = int(model.n_joints)
    has_tau = all(f"tau{j + 1}" in recording.names for j in range(nj))
    if measured and not has_tau:
        raise InputError(
            f"measured=True needs the torque channels tau1..tau{nj} in the recording; it has "
            f"{list(recording.names)}."
        )
    rows = idim_rows(
        model,
        recording,
        info=info,
        differentiation=differentiation,
        cutoff=cutoff,
        half_width=half_width,
        decimate=decimate,
        torque=False,
    )
    return torque_recording(
        model,
        rows.t,
        rows.W @ beta,
        rows.tau if measured else None,
        metadata={
            "prediction": "inverse model tau = W beta on the rows filtered and decimated as in "
            "the fit",
            "differentiation": differentiation,
            "cutoff": rows.cutoff,
            "half_width": rows.half_width,
            "decimate": rows.decimate,
        },
    )


def torque_recording(model, t, tau_hat, tau_measured=None, *, metadata=None):
    """A predicted-torque `Recording`: ``tau1..taun`` [N·m, N on prismatic joints], then
    ``tau1_measured..`` when ``tau_measured`` (same shape as ``tau_hat``) is given.

    The one output shape of every inverse-model prediction (IDIM's `predict_torque`,
    input-error's `physid.estimators.input_error.prepare.predict_torque`).
    """
    from ...signals.recording import Recording

    nj = int(model.n_joints)
    types = tuple(getattr(model, "joint_types", ()) or ("revolute",) * nj)
    units = ["N" if k == "prismatic" else "N*m" for k in types]
    names = [f"tau{j + 1}" for j in range(nj)]
    data = tau_hat
    if tau_measured is not None:
        names += [f"tau{j + 1}_measured" for j in range(nj)]
        data = np.concatenate([tau_hat, tau_measured], axis=1)
        units = units + units
    return Recording(t, data, names, units=units, metadata=metadata or {})
