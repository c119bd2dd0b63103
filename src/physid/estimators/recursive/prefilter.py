"""The recursive estimator's pre-filter settings: the default cut-off and the filter's order."""

from __future__ import annotations

import numpy as np

from ..._validate import check_int, check_positive
from ...models.linear_ode import LinearODEModel


def default_prefilter_cutoff(dt: float, characteristic_frequency: float | None = None) -> float:
    """Default SVF cut-off [Hz]: ``min(10 f_model, f_s / 10)``, or ``f_s / 20`` without a model.

    ``f_model`` [Hz] is the largest ``|root| / 2π`` of the model's nominal characteristic polynomial
    (for the MSD: ω0 / 2π). Ten times the model's frequency passes its dynamics and a sinusoidal
    input up to Z ≈ 10 with little attenuation; ``f_s / 10`` keeps ``ω_c·dt ≤ 0.63`` so the
    discretised filter stays well conditioned. The SVF adds no bias whatever the cut-off; it only
    trades noise suppression against excitation.

    Parameters
    ----------
    dt : float [s]
        Sample period (f_s = 1 / dt).
    characteristic_frequency : float, optional [Hz]
        ``f_model``; None, non-finite or ≤ 0 means unknown.

    Returns
    -------
    float [Hz]
        The cut-off.

    Examples
    --------
    The paper's MSD (ω0 = √(400/3) rad/s, f_model = 1.838 Hz) at 1 kHz, and no model:

    >>> round(default_prefilter_cutoff(1e-3, np.sqrt(400 / 3) / (2 * np.pi)), 2)
    18.38
    >>> default_prefilter_cutoff(1e-3)
    50.0
    """
    fs = 1.0 / dt
    if (
        characteristic_frequency is None
        or not np.isfinite(characteristic_frequency)
        or (characteristic_frequency <= 0)
    ):
        return fs / 20.0
    return float(min(10.0 * characteristic_frequency, fs / 10.0))


def _model_frequency(spec: LinearODEModel) -> float | None:
    try:
        a = [float(spec.parameters[name]) for name in spec.a_names]
    except (KeyError, TypeError, ValueError):
        return None
    roots = np.roots(np.r_[1.0, a[::-1]])  # s^n + a_{n-1} s^{n-1} + ... + a_0
    if roots.size == 0:
        return None
    return float(np.max(np.abs(roots)) / (2 * np.pi))


def _prefilter_settings(spec, dt, prefilter_cutoff, prefilter_order, discard):
    """The pre-filter's settings, shared by `build_regression` and the streaming estimator so that
    both filter alike: (highest derivative order, cut-off [Hz], Butterworth order, samples to
    discard or None for the filter's own transient)."""
    check_int(discard, "transient_samples", minimum=0, allow_none=True)
    highest = max(spec.order, spec.input_order)
    cutoff = (
        default_prefilter_cutoff(dt, _model_frequency(spec))
        if prefilter_cutoff is None
        else check_positive(prefilter_cutoff, "prefilter_cutoff")
    )
    order = highest + 1 if prefilter_order is None else int(prefilter_order)
    return highest, cutoff, order, (None if discard is None else int(discard))
