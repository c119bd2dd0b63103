"""Figures of the algebraic estimator: estimates against time with the invalid windows shaded."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

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

__all__ = ["plot_algebraic"]


def _spans(mask: np.ndarray):
    """(start, stop) index pairs of the runs of True in ``mask``."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1, strict=True)


@styled
def plot_algebraic(
    result, names: Sequence[str] | None = None, truth: Mapping[str, float] | None = None, ax=None
):
    """Plot per-window estimates against the window end time ``t0``.

    Parameters
    ----------
    result : AlgebraicResult
    names : sequence of str, optional
        Series to plot (default: the estimated coefficients, plus ω0 and ζ for the MSD).
    truth : mapping name -> value, optional
        Reference values drawn as dashed lines.
    ax : matplotlib Axes, optional
        Draw the first series there (its figure is returned); other series are skipped.

    Returns
    -------
    matplotlib.figure.Figure
        One axis per series; grey bands mark windows that do not exist or failed the determinant
        guard, the dotted line the final estimate (``result.parameters``: pooled least squares
        over the valid windows by default, or their median with ``final="median"``).
    """
    from matplotlib.figure import Figure

    finals = {**dict(result.parameters), **dict(getattr(result, "derived", {}))}
    if names is None:
        names = list(result.names)
        if "natural_frequency" in finals:
            names += ["natural_frequency", "damping_ratio"]
    if ax is not None:
        fig, axes, names = ax.figure, [ax], list(names)[:1]
    else:
        fig = Figure(figsize=(FULL_WIDTH, panel_height(len(names), 2.0)), layout="constrained")
        axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    t = result.t
    invalid = ~np.asarray(result.valid, dtype=bool)
    for ax, name in zip(axes, names, strict=True):
        series = result.series(name)
        shown = np.where(result.valid, series, np.nan)
        ax.plot(t, shown, color=COLORS[0], lw=1.0, label="valid windows")
        for a, b in _spans(invalid):
            ax.axvspan(t[a], t[min(b + 1, t.size - 1)], color="0.85", lw=0)
        final = final_value(result, name)
        if final is not None:
            ax.axhline(final, **FINAL_STYLE, label=f"final estimate {final:.6g}")
        true = truth.get(name) if truth else None
        if true is not None:
            ax.axhline(true, **TRUTH_STYLE, label=f"true value {true:.6g}")
        limits = robust_limits(
            shown, truth=true, final=final, converged_fraction=1.0, percentiles=(5.0, 95.0)
        )
        if limits is not None:
            ax.set_ylim(*limits)
        unit = " [rad/s]" if name == "natural_frequency" else unit_of(result, name)
        ax.set_ylabel(f"{name}{unit}")
        legend_outside(ax)
    axes[-1].set_xlabel("window end t0 [s]")
    axes[0].set_title(
        f"Algebraic estimator (T = {result.window:g} s, μ = {result.mu}, {result.integration}, "
        f"block {result.block}); grey: invalid windows ({1 - result.valid_fraction:.0%})"
    )
    return fig
