"""Figures of rigid-body arm identification: excitation, bias per base parameter, torques.

* `plot_excitation` — the joint trajectories against their position limits (one panel per
  joint) and the base-regressor condition number against random trajectories;
* `plot_bias_bars` — relative bias of each base parameter for several methods (grouped bars,
  hatched so that they stay distinct in grey);
* `plot_torque_prediction` — measured and predicted torque per joint (small multiples).

Library code: figures are returned, never shown.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from .style import (
    COLORS,
    DROPPED_LABEL,
    FULL_WIDTH,
    figure_legend,
    legend_outside,
    panel_height,
    shade_dropped,
    styled,
)

__all__ = ["plot_excitation", "plot_bias_bars", "plot_torque_prediction"]

_HATCHES = ("", "//", "..", "xx")


@styled
def plot_excitation(
    t,
    q,
    limits: Mapping,
    random: Sequence[float],
    designed_cond=None,
    *,
    used: int | None = None,
    title: str | None = None,
) -> Figure:
    """Joint trajectories with their position limits, and condition numbers.

    Parameters
    ----------
    t : array_like (n,) [s]
    q : array_like (n, n_joints) [rad]
    limits : mapping
        With ``"position"`` (n_joints, 2) [rad] (NaN where unknown).
    random : sequence of float
        Condition numbers of random trajectories.
    designed_cond : float, optional
        Condition number of the designed trajectory.
    used : int, optional
        Index (from 0) of the random trajectory drawn above, when no designed one is given; its
        bar is highlighted.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    n = q.shape[1]
    ncols = 3
    nrows = int(np.ceil(n / ncols)) + 1
    fig = Figure(figsize=(FULL_WIDTH, panel_height(nrows, 1.9, 1.0)), layout="constrained")
    grid = fig.add_gridspec(nrows, ncols)
    pos = np.asarray(limits.get("position", np.full((n, 2), np.nan)), float)
    for j in range(n):
        ax = fig.add_subplot(grid[j // ncols, j % ncols])
        ax.plot(t, q[:, j], color=COLORS[j % len(COLORS)], label="trajectory")
        for bound in pos[j]:
            if np.isfinite(bound):
                ax.axhline(bound, color="black", ls="--", lw=0.8, label="position limit")
        ax.set_title(f"joint {j + 1}")
        ax.set_xlabel("t [s]")
        ax.set_ylabel(f"q{j + 1} [rad]")
    ax = fig.add_subplot(grid[nrows - 1, :])
    values = list(random)
    labels = [f"random {i + 1}" for i in range(len(values))]
    colours = [COLORS[5]] * len(values)
    if used is not None and designed_cond is None:
        colours[used] = COLORS[1]
        labels[used] += " (drawn above)"
    if designed_cond is not None:
        values = [designed_cond, *values]
        labels = ["designed", *labels]
        colours = [COLORS[1], *colours]
    ax.bar(range(len(values)), values, color=colours, edgecolor="black", linewidth=0.5)
    ax.axhline(
        float(np.median(random)),
        color="black",
        ls=":",
        lw=1.0,
        label="median of the random trajectories",
    )
    if max(values) > 20 * min(values):
        ax.set_yscale("log")
    ax.set_xticks(range(len(values)), labels, rotation=90, fontsize=7)
    ax.set_xlabel("trajectory [–]")
    ax.set_ylabel("condition number [–]")
    ax.set_title("Condition number of the base regressor (lower is better)")
    legend_outside(ax)
    if title:
        fig.suptitle(title)
    return fig


@styled
def plot_bias_bars(
    names: Sequence[str],
    bias: Mapping[str, Mapping[str, float]],
    well: Sequence[str] = (),
    *,
    title: str | None = None,
) -> Figure:
    """Relative bias of each base parameter, one bar per method.

    Parameters
    ----------
    names : sequence of str
        Base parameters (x axis).
    bias : mapping method -> (mapping name -> relative bias)
    well : sequence of str
        Well-excited parameters; the others are drawn with a grey tick label.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    names = list(names)
    x = np.arange(len(names))
    k = len(bias)
    width = 0.8 / max(k, 1)
    fig = Figure(figsize=(FULL_WIDTH, panel_height(1, 3.0, 1.4)), layout="constrained")
    ax = fig.add_subplot()
    for i, (method, values) in enumerate(bias.items()):
        v = np.array([100 * abs(values[n]) if values[n] is not None else np.nan for n in names])
        ax.bar(
            x + (i - (k - 1) / 2) * width,
            v,
            width,
            color=COLORS[i % len(COLORS)],
            hatch=_HATCHES[i % len(_HATCHES)],
            edgecolor="black",
            linewidth=0.4,
            label=method,
        )
    ax.set_yscale("log")
    ax.set_xticks(x, names, rotation=90, fontsize=7)
    for label in ax.get_xticklabels():
        if well and label.get_text() not in well:
            label.set_color("grey")
    ax.set_xlabel("base parameter (grey: not well excited) [–]" if well else "base parameter [–]")
    ax.set_ylabel("|bias| / |truth| [%]")
    ax.set_title(title or "Bias of each base parameter over the seeds")
    legend_outside(ax)
    return fig


@styled
def plot_torque_prediction(t, measured, predicted, *, title: str | None = None) -> Figure:
    """Measured and predicted torque per joint, one panel each.

    Parameters
    ----------
    t : array_like (n,) [s]
    measured, predicted : array_like (n, n_joints) [N·m]
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    measured = np.asarray(measured, float)
    predicted = np.asarray(predicted, float)
    n = measured.shape[1]
    t = np.arange(measured.shape[0]) if t is None else np.asarray(t, float)
    ncols = 2
    nrows = int(np.ceil(n / ncols))
    fig = Figure(figsize=(FULL_WIDTH, panel_height(nrows, 1.8, 1.1)), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, sharex=True)
    for j in range(nrows * ncols):
        ax = axes[j // ncols, j % ncols]
        if j >= n:
            ax.set_visible(False)
            continue
        # a dropped equation (near rest) is NaN: a gap in a shaded span, never a torque of 0
        shade_dropped(ax, t, ~(np.isfinite(measured[:, j]) & np.isfinite(predicted[:, j])))
        ax.plot(t, measured[:, j], color=COLORS[0], lw=1.2, label="measured (filtered)")
        ax.plot(t, predicted[:, j], color=COLORS[1], lw=1.0, ls="--", label="predicted")
        ax.set_title(f"joint {j + 1}")
        ax.set_ylabel(f"τ{j + 1} [N·m]")
        ax.set_xlabel("t [s]")
    legend_ax = next(
        (
            ax
            for ax in axes.flat
            if ax.get_visible() and DROPPED_LABEL in ax.get_legend_handles_labels()[1]
        ),
        axes[-1, 0],
    )
    figure_legend(fig, legend_ax, ncol=3)
    if title:
        fig.suptitle(title)
    return fig
