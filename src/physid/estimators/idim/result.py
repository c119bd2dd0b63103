"""IDIM stage 7: the result of a fit (`IDIMResult`).

Part of `physid.estimators.idim`: a frozen dataclass with the one result schema
(`physid.estimators.results.ResultMixin`), built by `.estimator.IDIMEstimator.fit`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import InputError
from ..consistent import ConsistentEstimate
from ..results import ResultMixin
from .predict import predict_torque
from .rows import IDIMRows

__all__ = ["IDIMResult"]


@dataclass(frozen=True)
class IDIMResult(ResultMixin):
    """Estimates of an IDIM fit (OLS, WLS or IV) of the base parameters.

    Attributes
    ----------
    names : tuple of str
        Base parameters as ``model.base_parameters()`` names them: ``"ZZ1R"`` when other
        columns are regrouped into the kept column ``ZZ1`` (see `BaseInfo.names`). A model's
        ``params=`` refuses these names: they are not standard parameters.
    parameters : dict name -> float
        Base-parameter estimates (SI units).
    base_expressions : dict name -> str
        What each base parameter is, as a combination of the standard parameters (the key
        input-error's base-parameter results use too; result files written before carried it
        as ``expressions``, which `expressions` still reads).
    columns : tuple of str
        The regressor column kept for each base parameter (``"ZZ1"``), in the order of `names`.
    stderr : dict name -> float or None
        Standard errors (`stderr_method`), or None with `stderr_reason`.
    stderr_reason : str or None
    stderr_method : str
        ``"hac"`` (Newey–West sandwich, lag `hac_lag`) or ``"iid"``.
    covariance : ndarray, shape (p, p)
    derived : dict
        With ``consistent=True``: the standard parameters of the consistent estimate.
    units : dict name -> str
    method : str
        ``"idim-ols"``, ``"idim-wls"`` or ``"idim-iv"``.
    success : bool
    message : str
    condition_number : float
        Column-scaled condition number of the base regressor as solved: its rows weighted by
        the fit's per-joint weights (``1/σ̂_j`` for WLS and IV, ones for OLS). The message and
        `summary` quote this number.
    relative_error : dict
        ``‖τ̂ − τ‖ / ‖τ‖`` on the fitted (filtered, decimated) rows: ``"overall"`` and
        ``"tau1"``… per joint.
    joint_sigma : dict
        Residual standard deviation per joint [N·m] (the WLS weights are their inverses).
    n_rows : int
        Decimated time rows used (each holds n_joints equations).
    n_recordings : int
    cutoff : float [rad/sample]
    half_width : int
    decimate : int
    dt : float [s]
        Sample period of the fitted recordings (`cutoff` is in rad/sample of this period).
    differentiation : str
    iterations : int
        IV iterations (0 for OLS/WLS).
    iv_changes : tuple of float
        Relative change of the estimate per IV iteration.
    consistent : ConsistentEstimate or None
    warnings : tuple of str
    history : ndarray, shape (n_steps, p)
        The estimate after each step (OLS, then WLS/IV iterations).
    t : ndarray, shape (n_rows,) [s]
    residuals : ndarray, shape (n_rows, n_joints) [N·m]
    model : ChainModel or None
        The model fitted (used by `predict`; not written by ``to_dict``).
    stick_threshold : "auto", float or None
        The fit's ``stick_threshold`` (`validate` drops the same equations).
    reversal_joints : tuple of int
        Joints (1-based) whose equations next to a speed reversal or at low speed the fit
        dropped because the residual showed friction the model does not explain there
        (``stick_threshold="auto"``; `physid.estimators._stiction.reversal_samples`).
    """

    names: tuple[str, ...]
    parameters: dict[str, float]
    base_expressions: dict[str, str]
    columns: tuple[str, ...]
    stderr: dict[str, float] | None
    stderr_reason: str | None
    stderr_method: str
    covariance: np.ndarray
    derived: dict[str, float]
    units: dict[str, str]
    method: str
    success: bool
    message: str
    condition_number: float
    relative_error: dict[str, float]
    joint_sigma: dict[str, float]
    n_rows: int
    n_recordings: int
    cutoff: float
    half_width: int
    decimate: int
    dt: float
    differentiation: str
    hac_lag: int
    iterations: int
    iv_changes: tuple[float, ...]
    consistent: ConsistentEstimate | None
    warnings: tuple[str, ...]
    history: np.ndarray = field(repr=False)
    t: np.ndarray = field(repr=False)
    residuals: np.ndarray = field(repr=False)
    model: Any = field(default=None, repr=False, compare=False)
    stick_threshold: float | str | None = None
    reversal_joints: tuple = ()

    _history_fields = ("history", "t", "residuals", "covariance")
    _private_fields = ("model",)
    _unpicklable_fields = ("model",)  # compiled kernels (ctypes): pickled as None

    @property
    def expressions(self) -> dict[str, str]:
        """The former name of `base_expressions` (deprecated: read ``base_expressions``)."""
        warnings.warn(
            "IDIMResult.expressions is deprecated: read result.base_expressions (the name "
            "every base-parameter result uses).",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.base_expressions

    def beta_vector(self) -> np.ndarray:
        """The estimates as an array ordered like `names`."""
        return np.array([self.parameters[n] for n in self.names])

    def summary(self) -> str:
        """Estimates ± standard errors, the condition number, the relative torque errors."""
        lines = [super().summary()]
        lines.append(
            f"  condition number {self.condition_number:.4g}; relative torque error "
            f"{self.relative_error['overall']:.4g} overall ("
            + ", ".join(f"{k} {v:.3g}" for k, v in self.relative_error.items() if k != "overall")
            + f"); {self.n_rows} rows, decimate {self.decimate}, cutoff {self.cutoff:.3g} "
            "rad/sample"
        )
        if self.iterations:
            lines.append(
                f"  IV: {self.iterations} iterations, relative change per iteration "
                + ", ".join(f"{c:.2g}" for c in self.iv_changes)
            )
        if self.consistent is not None:
            c = self.consistent
            lines.append(
                f"  consistent estimate: cost ratio {c.cost_ratio:.4g}; at the boundary: "
                + (", ".join(c.at_boundary) or "none")
            )
        return "\n".join(lines)

    def predict_rows(self, rows: IDIMRows) -> np.ndarray:
        """τ̂ = W β̂ on rows built like the fit's (`idim_rows`), shape (n_rows, n_joints)."""
        return rows.W @ self.beta_vector()

    def predict(self, recording, *, measured: bool = False):
        """Torques the identified base parameters predict from a recording's motion.

        The recording's q goes through the fit's own state filter (`differentiation`,
        `cutoff`, `half_width`) and the base regressor through the fit's parallel filter and
        decimation (`decimate`): the prediction is ``τ̂ = W β̂`` on the *filtered, decimated
        rows* (the robotics convention for the cross-test), not at every input sample. See
        `predict_torque`.

        Parameters
        ----------
        recording : Recording
            ``t`` [s] and ``q1..qn`` [rad | m], sampled like the fit's recordings;
            ``tau1..taun`` are needed only with ``measured=True``.
        measured : bool
            Also return the recording's torques through the same filter and decimation, as
            channels ``tau1_measured..``.

        Returns
        -------
        Recording
            Time of the kept rows [s]; ``tau1..taun`` predicted [N·m | N] (and the measured
            ones); ``metadata`` records the filter settings and ``"prediction"``.

        Raises
        ------
        InputError
            The result holds no model (a result built by hand): use `predict_torque`.
        """
        if self.model is None:
            raise InputError(
                "this IDIMResult holds no model; call "
                "physid.estimators.idim.predict_torque(model, result.names, "
                "result.beta_vector(), recording, ...) instead."
            )
        return predict_torque(
            self.model,
            self.names,
            self.beta_vector(),
            recording,
            differentiation=self.differentiation,
            cutoff=self.cutoff,
            half_width=self.half_width,
            decimate=self.decimate,
            measured=measured,
        )
