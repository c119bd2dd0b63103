"""The recursive estimator's result."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import InputError
from .._linear import LinearODEResultMixin, simulate_prediction
from ..results import ResultMixin


@dataclass(frozen=True, eq=False)
class RecursiveResult(LinearODEResultMixin, ResultMixin):
    """Result of `RecursiveLeastSquares.fit`.

    Attributes
    ----------
    t : ndarray (n_samples,) [s] — the recording's time.
    estimates : ndarray (n_samples, p) — θ̂ at every sample (NaN before initialisation).
    covariance : ndarray (n_samples, p, p) or (n_samples, p) — eq. 3's P at every sample (in units
        of R; multiply by the noise variance / R for a covariance), or its diagonal.
    names : tuple of str — the unknown of each column.
    parameters : dict — final estimates of the fitted coefficients.
    derived : dict — for the MSD ``natural_frequency`` [rad/s] and ``damping_ratio`` (and m, c,
        k with a force input: ``mass``, ``damping``, ``stiffness``); for a model whose
        coefficients are expressions of physical parameters (``a = ["k/m", "c/m"]``), those
        parameters where the coefficients determine them (see ``physical``).
    derived_stderr : dict or None — standard errors of ``derived`` by the delta method from
        ``final_covariance``; None whenever ``stderr`` is None.
    final_covariance : ndarray (p, p) or None — covariance of the final θ̂ (SI, ordered like
        ``names``, diagonal ``stderr``²; not ``covariance``, which is P at every sample); None
        whenever ``stderr`` is None.
    physical : dict or None — for a model in physical terms, `PhysicalParameters.to_dict` of the
        final estimate (values, stderr, identifiable, unidentifiable, combinations, message; the
        message also ends ``message`` when physical parameters are not identifiable).
    stderr : dict or None — standard errors of the final θ̂: white noise on the measured output
        propagated exactly through the state-variable filter (`_output_noise_covariance`;
        Newey–West HAC for the differential pre-filter); ``metadata["stderr_method"]`` names it
        and ``metadata["stderr_white_rows"]`` keeps the white-row formula. None with
        ``stderr_reason`` where they cannot be given.
    natural_frequency, damping_ratio : ndarray (n_samples,) or None — MSD only.
    valid_fraction : float — share of samples with a defined estimate.
    forgetting, weight, prefilter_cutoff [Hz], discarded (samples), init_end (sample index).
    """

    t: np.ndarray
    estimates: np.ndarray
    covariance: np.ndarray
    names: tuple[str, ...]
    parameters: dict[str, float]
    stderr: dict[str, float]
    natural_frequency: np.ndarray | None
    damping_ratio: np.ndarray | None
    valid_fraction: float
    forgetting: float
    weight: float
    prefilter: str
    prefilter_cutoff: float
    discarded: int
    init_end: int
    success: bool
    message: str
    metadata: dict[str, Any] = field(default_factory=dict)
    derived: dict[str, float] = field(default_factory=dict)
    stderr_reason: str | None = None
    derived_stderr: dict[str, float] | None = None
    final_covariance: np.ndarray | None = None
    physical: dict | None = None
    units: dict[str, str] = field(default_factory=dict)
    known: dict[str, float] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    model_name: str = ""
    fit_percent: float = float("nan")
    model: Any = field(default=None, repr=False, compare=False)

    method = "rls"
    _history_fields = ("t", "estimates", "covariance", "natural_frequency", "damping_ratio")
    _private_fields = ("model",)

    @property
    def valid(self) -> np.ndarray:
        """Samples with a defined estimate, shape (n_samples,) (as the algebraic result's)."""
        return np.all(np.isfinite(self.estimates), axis=1)

    def series(self, name: str) -> np.ndarray:
        """Per-sample estimate of one unknown, or (MSD) ``natural_frequency``/``damping_ratio``."""
        if name in self.names:
            return self.estimates[:, self.names.index(name)].copy()
        if name == "natural_frequency" and self.natural_frequency is not None:
            return self.natural_frequency.copy()
        if name == "damping_ratio" and self.damping_ratio is not None:
            return self.damping_ratio.copy()
        raise InputError(
            f"no per-sample series {name!r}; available: {list(self.names)}"
            + ("" if self.natural_frequency is None else " and natural_frequency, damping_ratio")
            + "."
        )

    def plot(self, truth: Mapping[str, float] | None = None, ax=None, physical=None):
        """θ̂ (and ω0 for the MSD), or the model's physical parameters, against time.

        Parameters
        ----------
        truth : mapping, optional
            True values drawn as dashed lines.
        ax : matplotlib Axes, optional
            Draw the last panel (ω0 for the MSD) there.
        physical : bool, optional
            Plot the physical parameters the model declares (m, c, k of ``msd-force``) with
            their final value and 95 % interval (`physid.report.physical.plot_physical`);
            default: whenever the model declares some the estimate determines.

        Returns
        -------
        matplotlib.figure.Figure
        """
        if physical is None:
            physical = ax is None and bool((self.physical or {}).get("identifiable"))
        if physical:
            from ...report.physical import plot_physical

            title = f"recursive least squares, λ = {self.forgetting:g}"
            return plot_physical(self, truth=truth, title=title)
        from ...report.recursive import plot_recursive

        return plot_recursive(self, truth=truth, ax=ax)


#: Below this output-error fit [%] on the fitted record the model "explains nothing" (pure noise
#: gives about 0 %, white output noise at 0 dB SNR 29 %, at 10 dB 68 %).
MIN_FIT_PERCENT = 10.0


def _training_fit(spec, values, recording, in_name, out_name) -> float:
    """Output-error fit [%] of the identified model on the fitted record (NaN if not defined)."""
    y = np.asarray(recording[out_name], dtype=float)
    y_hat, _ = simulate_prediction(spec, values, recording.t, recording[in_name], y)
    spread = float(np.linalg.norm(y - y.mean()))
    if not np.all(np.isfinite(y_hat)) or spread == 0.0:
        return float("nan")
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / spread)


def _jsonable_settings(params: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for k, v in params.items():
        if k == "model":
            v = getattr(v, "name", v) if not isinstance(v, str) else v
        elif isinstance(v, (tuple, list)):
            v = list(v)
        elif isinstance(v, Mapping):
            v = dict(v)
        out[k] = v
    return out
