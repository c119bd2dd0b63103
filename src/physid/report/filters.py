"""Figures of the differential filters (Cedro & Janecki, section 3).

* `plot_frequency_responses` — |H(Ω)| of designed filters against the ideal, in dB.
* `plot_derivative_estimates` — a noisy signal, its low-passed value and derivative estimates
  against the truth.
* `derivative_demo_figure` — the same on a built-in noisy multisine (for the demo).

Functions return a `matplotlib.figure.Figure` built without pyplot (no ``plt.show``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from ..errors import InputError
from ..signals.noise import add_white_noise

__all__ = ["plot_frequency_responses", "plot_derivative_estimates", "derivative_demo_figure"]

_TITLES = {0: "low-pass (Filtr)", 1: "first derivative (Filtr1)", 2: "second derivative (Filtr2)"}


def _db(magnitude: np.ndarray) -> np.ndarray:
    """20 log10 |.|, with exact zeros shown as gaps (NaN) rather than -inf."""
    with np.errstate(divide="ignore"):
        out = 20 * np.log10(np.abs(magnitude))
    out[~np.isfinite(out)] = np.nan
    return out


def plot_frequency_responses(filters: Sequence, omega=None, *, floor_db: float = -140.0) -> Figure:
    """Magnitude responses of designed filters against their ideal responses, in dB.

    Parameters
    ----------
    filters : sequence of physid.filters.DifferentialFilter
        One panel each (e.g. the low-pass, first- and second-derivative filters of one design).
    omega : array_like, optional [rad/sample]
        Frequencies; default 4000 points on (0, π].
    floor_db : float
        Lower limit of the y axes, relative to each panel's pass-band peak [dB].

    Returns
    -------
    matplotlib.figure.Figure
        Per panel: the designed |H| (solid), the ideal (dashed; 0 outside the band, not drawn),
        and vertical lines at Ω_g and 1.5 Ω_g. The y axis is dB re 1 (low-pass) or re 1/s^k.
    """
    filters = list(filters)
    if not filters:
        raise InputError("plot_frequency_responses needs at least one filter.")
    omega = np.linspace(np.pi / 4000, np.pi, 4000) if omega is None else np.asarray(omega, float)
    fig = Figure(figsize=(7, 2.4 * len(filters)), layout="constrained")
    axes = fig.subplots(len(filters), 1, sharex=True, squeeze=False)[:, 0]
    for ax, filt in zip(axes, filters, strict=True):
        designed = _db(filt.frequency_response(omega))
        ideal = _db(filt.ideal_response(omega))
        ax.plot(omega, designed, label=f"Harris-windowed, M={filt.half_width}")
        ax.plot(omega, ideal, "--", label="ideal")
        ax.axvline(filt.cutoff, color="0.4", linewidth=0.8)
        ax.axvline(1.5 * filt.cutoff, color="0.4", linewidth=0.8, linestyle=":")
        peak = np.nanmax(designed[omega <= filt.cutoff]) if np.any(omega <= filt.cutoff) else 0.0
        ax.set_ylim(peak + floor_db, peak + 10)
        unit = "" if filt.order == 0 else (" re 1/s" if filt.order == 1 else " re 1/s²")
        ax.set_ylabel(f"|H| [dB{unit}]")
        ax.set_title(f"{_TITLES[filt.order]}, Ω_g = {filt.cutoff:g} rad/sample", fontsize="medium")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower left", fontsize="small")
    axes[-1].set_xlabel("Ω [rad/sample]  (vertical lines: Ω_g and 1.5 Ω_g)")
    return fig


def plot_derivative_estimates(
    t, x, result, truth: Mapping[str, np.ndarray] | None = None, *, channel: int = 0
) -> Figure:
    """A noisy signal with its filtered value and first/second derivative estimates.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
        Input sample times.
    x : array_like, shape (n_samples,) or (n_samples, n_channels)
        The (noisy) input signal.
    result : physid.filters.FilteredDerivatives
        From ``filter_derivatives(x, t, ...)``.
    truth : mapping, optional
        ``{"value": ..., "first": ..., "second": ...}`` sampled at ``t`` (same shape as ``x``);
        any subset. Drawn dashed on the matching panel.
    channel : int
        Which channel to show.

    Returns
    -------
    matplotlib.figure.Figure
        Three panels: value (noisy input, estimate, truth), first and second derivative
        (estimate, truth).
    """
    t = np.asarray(t, dtype=float)
    x2 = np.asarray(x, dtype=float).reshape(t.size, -1)
    truth = dict(truth or {})
    unknown = set(truth) - {"value", "first", "second"}
    if unknown:
        raise InputError(f"truth keys must be 'value', 'first', 'second'; got {sorted(unknown)}.")
    idx = np.searchsorted(t, result.t)
    fig = Figure(figsize=(8, 7), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    labels = {"value": "x", "first": "dx/dt", "second": "d²x/dt²"}
    for ax, key in zip(axes, ("value", "first", "second"), strict=True):
        estimate = np.asarray(getattr(result, key)).reshape(result.t.size, -1)[:, channel]
        if key == "value":
            ax.plot(t, x2[:, channel], color="0.7", linewidth=0.6, label="measured (noisy)")
        ax.plot(result.t, estimate, linewidth=1.2, label="filtered estimate")
        if key in truth:
            true = np.asarray(truth[key], dtype=float).reshape(t.size, -1)[:, channel]
            ax.plot(t[idx], true[idx], "--", linewidth=1.0, label="true")
        ax.set_ylabel(labels[key])
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")
    axes[0].set_title(
        f"M = {result.half_width}, Ω_g = {result.cutoff:g} rad/sample "
        f"(delay {result.delay} samples, shown at the true times)",
        fontsize="medium",
    )
    axes[-1].set_xlabel("t [s]")
    return fig


def derivative_demo_figure(
    *,
    half_width: int = 100,
    cutoff: float = 0.2,
    dt: float = 1e-3,
    duration: float = 2.0,
    snr_db: float = 40.0,
    seed: int = 0,
) -> Figure:
    """The filters on a noisy multisine (2, 5 and 9 Hz) with its exact derivatives.

    The noise is white and Gaussian with standard deviation ``rms(x) · 10^(-snr_db/20)``
    (seeded with ``seed``).
    """
    from ..filters import filter_derivatives

    t = dt * np.arange(int(round(duration / dt)) + 1)
    freqs = 2 * np.pi * np.array([2.0, 5.0, 9.0])  # [rad/s]
    amps = np.array([1.0, 0.5, 0.25])
    phases = np.array([0.0, 1.0, 2.0])
    arg = np.outer(t, freqs) + phases
    value = np.sin(arg) @ amps
    first = np.cos(arg) @ (amps * freqs)
    second = -np.sin(arg) @ (amps * freqs**2)
    noisy, _ = add_white_noise(value, snr_db=snr_db, rng=seed)
    result = filter_derivatives(noisy, t, half_width, cutoff)
    fig = plot_derivative_estimates(
        t, noisy, result, {"value": value, "first": first, "second": second}
    )
    fig.suptitle(f"Noisy multisine, SNR {snr_db:g} dB", fontsize="medium")
    return fig
