"""Inverse dynamic identification model (IDIM): least squares, weighted LS, instrumental variables.

The robotics way of identifying a rigid-body arm (Gautier, "Dynamic identification of robots
with power model", 1997; Gautier & Khalil 1990 for the base parameters; Janot, Vandanjon &
Gautier, "A generic instrumental variable approach for industrial robot identification", IEEE
TCST 2014, for IDIM-IV).

Pipeline (one recording at a time; several recordings are stacked *after* it, so that no filter
ever runs across the seam between two experiments)::

    q  ──► q^f, q̇^f, q̈^f                 (state filter: physid's consistent FIR bank, or a
                                           zero-phase Butterworth + central differences)
       ──► W = Y(q^f, q̇^f, q̈^f)[:, :, independent]      the base regressor (n, n_joints, p)
    [W | τ] ──► low-pass along time, keep one sample in nd      ("parallel filtering and
                                                                  decimation", every column)
       ──► β̂ = argmin ‖W β − τ‖²                (OLS; WLS: rows of joint j weighted by 1/σ̂_j)

IDIM-IV replaces the noisy regressor in the normal equations by an instrument Z from a simulated
closed loop of the current estimate (`.iv`). Standard errors come from a sandwich that knows the
parallel filter's correlation, or a HAC or iid estimate (`.uncertainty`).

Layout
------
One module per stage, each with a plain contract (arrays in, arrays out); every name is
importable from here:

* `.filtering` — the state filter (`states`, `auto_cutoff`);
* `.base_parameters` — `BaseInfo`, `base_regressor_info`, `base_regressor`, units (shared with
  input-error over base parameters);
* `.decimation` — `parallel_decimate`;
* `.rows` — `IDIMRows`, `idim_rows` (filtering -> regressor -> decimation -> row selection,
  `physid.estimators._stiction`);
* `.solve` — OLS/WLS/IV solves, `condition_number`, the excitation check;
* `.uncertainty` — `hac_covariance` and the covariance of the estimate;
* `.iv` — the closed-loop simulation that gives IV its instruments;
* `.predict` — `predict_torque`, `torque_recording`;
* `.result` — `IDIMResult`;
* `.estimator` — `IDIMEstimator`;
* `.stream` — `fit_streamed`: the same fit over records of any length in bounded memory, read
  block by block (`.stream_plan` survey, `.stream_window` windows, `.stream_moments`
  accumulators, `.stream_fit` solve).

The methods ``"idim-ols"``, ``"idim-wls"`` and ``"idim-iv"`` of `physid.estimators.make` build
`IDIMEstimator` (`physid.estimators.registry` names them; nothing here imports the registry).
"""

from __future__ import annotations

from ..consistent import ConsistentEstimate
from .base_parameters import BaseInfo, base_regressor, base_regressor_info, joint_of, unit_of
from .decimation import decimated_noise_correlation, decimation_edge, parallel_decimate
from .estimator import (
    METHODS,
    REL_ERROR_FAIL,
    REL_ERROR_FAIL_JOINT,
    IDIMEstimator,
    _check_all_unknown,
)
from .filtering import DIFFERENTIATIONS, auto_cutoff, butterworth_states, consistent_bank, states
from .iv import IV_ATOL, IV_RTOL, params_for_base
from .predict import predict_torque, torque_recording
from .result import IDIMResult
from .rows import IDIMRows, _recording_arrays, idim_rows
from .solve import (
    COND_REFUSE,
    COND_WARN,
    UNEXCITED_RTOL,
    ConditionWarning,
    condition_number,
    iv_solve,
    joint_sigma,
    lstsq,
)
from .stream import fit_streamed
from .uncertainty import _correlation_length, _newey_west_lag, hac_covariance

__all__ = [
    "IDIMEstimator",
    "IDIMResult",
    "fit_streamed",
    "IDIMRows",
    "ConditionWarning",
    "idim_rows",
    "predict_torque",
    "parallel_decimate",
    "base_regressor_info",
    "hac_covariance",
    "condition_number",
    "METHODS",
]

#: The names this module had as a single file, kept for callers (private ones included).
_lstsq = lstsq
_iv_solve = iv_solve
_joint_sigma = joint_sigma
_params_for_base = params_for_base
_unit_of = unit_of
_joint_of = joint_of
_states = states
_butterworth_states = butterworth_states
_consistent_bank = consistent_bank
_decimation_edge = decimation_edge
_decimated_noise_correlation = decimated_noise_correlation


def _base_regressor(model, info: BaseInfo, q, qd, qdd, block: int = 8192):
    """`base_regressor` on ``info``'s kept columns (the former signature)."""
    return base_regressor(model, info.columns, q, qd, qdd, block=block)


_KEPT = (
    BaseInfo,
    ConsistentEstimate,
    DIFFERENTIATIONS,
    COND_WARN,
    COND_REFUSE,
    UNEXCITED_RTOL,
    REL_ERROR_FAIL,
    REL_ERROR_FAIL_JOINT,
    IV_RTOL,
    IV_ATOL,
    auto_cutoff,
    torque_recording,
    _check_all_unknown,
    _recording_arrays,
    _correlation_length,
    _newey_west_lag,
)
