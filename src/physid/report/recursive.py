"""Figures of the recursive least-squares estimator: θ̂ (and ω0 for the MSD) against time."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.figure import Figure

from .style import (
    COLORS,
    FINAL_STYLE,
    FULL_WIDTH,
    TRUTH_STYLE,
    final_value,
    legend_outside,
    panel_height,
    robust_limits,
    styled,
    unit_of,
)

__all__ = ["plot_recursive"]


@styled
def plot_recursive(result, truth: Mapping[str, float] | None = None, ax=None) -> Figure:
    """Plot every estimated coefficient, and ω0 [rad/s] for the MSD, against time [s].

    The y axis of each panel is set by the converged part of the trace (percentiles of its
    second half, `physid.report.style.robust_limits`), never by the start-up transient; the final
    estimate is drawn dotted and the true value, where given, dashed.

    Parameters
    ----------
    result : RecursiveResult
        From `physid.estimators.recursive.RecursiveLeastSquares.fit`.
    truth : mapping, optional
        True values (coefficient names and/or ``natural_frequency``) drawn as dashed lines.
    ax : matplotlib Axes, optional
        Draw the last panel (ω0 for the MSD) there (its figure is returned); others are skipped.

    Returns
    -------
    matplotlib.figure.Figure
    """
    truth = dict(truth or {})
    if "natural_frequency" not in truth and "theta2" in truth and truth["theta2"] > 0:
        truth["natural_frequency"] = float(np.sqrt(truth["theta2"]))
    series = [(name, result.estimates[:, i]) for i, name in enumerate(result.names)]
    if getattr(result, "natural_frequency", None) is not None:
        series.append(("natural_frequency", result.natural_frequency))
    if ax is not None:
        fig = ax.figure
        axes = [ax]
        series = series[-1:]
    else:
        fig = Figure(figsize=(FULL_WIDTH, panel_height(len(series), 2.0)), layout="constrained")
        axes = fig.subplots(len(series), 1, sharex=True, squeeze=False)[:, 0]
    for axis, (name, values) in zip(axes, series, strict=False):
        values = np.asarray(values, dtype=float)
        axis.plot(result.t, values, color=COLORS[0], lw=1.2, label="RLS estimate")
        final = final_value(result, name, values)
        if final is not None:
            axis.axhline(final, **FINAL_STYLE, label=f"final estimate {final:.5g}")
        true = truth.get(name)
        if true is not None:
            axis.axhline(true, **TRUTH_STYLE, label=f"true value {true:.5g}")
        limits = robust_limits(values, truth=true, final=final)
        if limits is not None:
            axis.set_ylim(*limits)
        label = "ω0" if name == "natural_frequency" else f"θ̂ {name}"
        unit = " [rad/s]" if name == "natural_frequency" else unit_of(result, name)
        axis.set_ylabel(f"{label}{unit}")
        legend_outside(axis)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(
        f"Recursive least squares, λ = {result.forgetting:g}, pre-filter {result.prefilter} "
        f"{result.prefilter_cutoff:.3g} Hz (y axes: converged part)"
    )
    return fig
