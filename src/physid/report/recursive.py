"""Figures of the recursive least-squares estimator: θ̂ (and ω0 for the MSD) against time."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.figure import Figure

__all__ = ["plot_recursive"]


def plot_recursive(result, truth: Mapping[str, float] | None = None, ax=None) -> Figure:
    """Plot every estimated coefficient, and ω0 [rad/s] for the MSD, against time [s].

    Parameters
    ----------
    result : RecursiveResult
        From `physid.estimators.recursive.RecursiveLeastSquares.fit`.
    truth : mapping, optional
        True values (coefficient names and/or ``natural_frequency``) drawn as dashed lines.
    ax : matplotlib Axes, optional
        Draw the first panel there (its figure is returned); other panels are skipped.

    Returns
    -------
    matplotlib.figure.Figure
    """
    truth = dict(truth or {})
    if "natural_frequency" not in truth and "theta2" in truth and truth["theta2"] > 0:
        truth["natural_frequency"] = float(np.sqrt(truth["theta2"]))
    series = [(name, result.estimates[:, i], "") for i, name in enumerate(result.names)]
    if result.natural_frequency is not None:
        series.append(("natural_frequency", result.natural_frequency, "rad/s"))
    if ax is not None:
        fig = ax.figure
        axes = [ax]
        series = series[-1:]
    else:
        fig = Figure(figsize=(7.0, 1.9 * len(series) + 0.6), layout="constrained")
        axes = fig.subplots(len(series), 1, sharex=True, squeeze=False)[:, 0]
    for axis, (name, values, unit) in zip(axes, series, strict=False):
        axis.plot(result.t, values, lw=1.0, label="RLS estimate")
        if name in truth:
            axis.axhline(truth[name], color="k", ls="--", lw=0.8, label="true")
            finite = values[np.isfinite(values)]
            if finite.size:  # zoom on the converged part, keep the true value visible
                tail = finite[finite.size // 2 :]
                span = max(np.ptp(np.r_[tail, truth[name]]), 1e-3 * abs(truth[name]) + 1e-12)
                centre = 0.5 * (tail.max() + tail.min()) if tail.size else truth[name]
                low, high = min(centre, truth[name]), max(centre, truth[name])
                axis.set_ylim(low - 2 * span, high + 2 * span)
        label = "ω0" if name == "natural_frequency" else f"θ̂ {name}"
        axis.set_ylabel(f"{label} [{unit}]" if unit else label)
        axis.grid(True, alpha=0.3)
    axes[0].legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(
        f"Recursive least squares, λ = {result.forgetting:g}, pre-filter {result.prefilter} "
        f"{result.prefilter_cutoff:.3g} Hz"
    )
    return fig
