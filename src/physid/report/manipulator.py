"""Figures of the manipulator identification (Cedro & Janecki, Figs. 4 and 5, and ours).

* `plot_parameter_histories` — every parameter over the residual evaluations, normalised by the
  true (or final) value: the paper's Figs. 4 and 5 show m1 and m2 this way, over ~1450 evaluations.
* `plot_valley` — the quality factor J over a grid of (m1, l1) with the curve m1·l1² = const: the
  valley along which an unconstrained 8-parameter fit wanders.
* `plot_residuals` — the equation residuals τ̂ − τ^f per joint at the estimate.
* `plot_input_error` — histories and residuals together (what ``InputErrorResult.plot()`` shows).
* `plot_filter_sweep` — bias of the estimates against the filter cut-off.

Library code: figures are returned, never shown.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from .style import (
    COLORS,
    FULL_WIDTH,
    LINESTYLES,
    MARKERS,
    TRUTH_STYLE,
    legend_outside,
    panel_height,
    robust_limits,
    styled,
)

__all__ = [
    "plot_parameter_histories",
    "plot_valley",
    "plot_residuals",
    "plot_input_error",
    "plot_filter_sweep",
    "plot_histories_and_search",
]

_COLORS = COLORS


def _names(result) -> tuple[str, ...]:
    return tuple(getattr(result, "parameter_names", None) or result.names)


def _reference(result, truth: Mapping[str, float] | None) -> np.ndarray:
    names = _names(result)
    if truth is None:
        return np.array([result.parameters[n] for n in names], dtype=float)
    return np.array([truth.get(n, result.parameters[n]) for n in names], dtype=float)


@styled
def plot_parameter_histories(
    result,
    truth: Mapping[str, float] | None = None,
    *,
    ax=None,
    paper_evaluations: int | None = None,
) -> Figure:
    """Each parameter at every residual evaluation, divided by its true (or final) value.

    Parameters
    ----------
    result : InputErrorResult
    truth : mapping name -> value, optional
        Values to normalise by (default: the final estimates).
    ax : matplotlib Axes, optional
        Draw into this axes instead of a new figure.
    paper_evaluations : int, optional
        Mark the paper's evaluation count (1450) for comparison.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        fig = Figure(figsize=(FULL_WIDTH, panel_height()), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    ref = _reference(result, truth)
    hist = np.asarray(result.history, dtype=float)
    evals = np.arange(1, hist.shape[0] + 1)
    for i, name in enumerate(_names(result)):
        label = f"{name} (held)" if name in result.fixed else name
        ax.plot(
            evals,
            hist[:, i] / ref[i],
            color=COLORS[i % len(COLORS)],
            linestyle=":" if name in result.fixed else LINESTYLES[i % len(LINESTYLES)],
            marker=MARKERS[i % len(MARKERS)],
            markersize=3,
            label=label,
        )
    ratio = hist / ref
    ax.axhline(1.0, **TRUTH_STYLE, label="true value" if truth is not None else "final estimate")
    limits = robust_limits(ratio, truth=1.0, converged_fraction=0.5)
    if limits is not None:
        ax.set_ylim(*limits)
    if paper_evaluations:
        ax.axvline(paper_evaluations, color="k", lw=0.8, ls=":")
        ax.text(
            paper_evaluations,
            ax.get_ylim()[1],
            f" paper: ~{paper_evaluations}",
            va="top",
            fontsize=8,
        )
    ax.set_xlabel("residual evaluation [count]")
    ax.set_ylabel("estimate / " + ("true value" if truth is not None else "final value") + " [–]")
    ax.set_title(f"Parameter histories ({hist.shape[0]} evaluations, {result.njev} Jacobians)")
    legend_outside(ax)
    return fig


@styled
def plot_residuals(result, *, ax=None) -> Figure:
    """Equation residuals ``τ̂ − τ^f`` [N·m] per joint against time at the estimate."""
    if ax is None:
        fig = Figure(figsize=(FULL_WIDTH, panel_height()), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    e = np.asarray(result.residuals)
    for j in range(e.shape[1]):
        rms = float(np.sqrt(np.mean(e[:, j] ** 2)))
        ax.plot(
            result.t,
            e[:, j],
            color=COLORS[j % len(COLORS)],
            linestyle=LINESTYLES[j % len(LINESTYLES)],
            lw=0.9,
            label=f"joint {j + 1} (rms {rms:.3g})",
        )
    ax.set_xlabel("t [s]")
    ax.set_ylabel("τ̂ − τ$^f$ [N·m]")
    ax.set_title(f"Residuals at the estimate, J = {result.cost:.4g}")
    legend_outside(ax)
    return fig


@styled
def plot_input_error(result, truth: Mapping[str, float] | None = None) -> Figure:
    """Parameter histories (top) and residuals (bottom) of an input-error fit."""
    fig = Figure(figsize=(FULL_WIDTH, panel_height(2)), layout="constrained")
    top, bottom = fig.subplots(2, 1)
    plot_parameter_histories(result, truth, ax=top)
    plot_residuals(result, ax=bottom)
    return fig


@styled
def plot_valley(
    m1,
    l1,
    cost,
    *,
    product: float,
    estimate: tuple[float, float] | None = None,
    paper_point: tuple[float, float] | None = None,
    start: tuple[float, float] | None = None,
    nelder_mead: tuple[float, float] | None = None,
) -> Figure:
    """The quality factor J over (m1, l1) with the curve ``m1·l1² = product``.

    Parameters
    ----------
    m1 : array_like, shape (nx,) [kg]
    l1 : array_like, shape (ny,) [m]
    cost : array_like, shape (ny, nx)
        J at each grid point (other parameters held).
    product : float [kg·m²]
        The identified m1·l1²; its curve is drawn.
    estimate, paper_point, start, nelder_mead : (m1, l1), optional
        Points to mark: our estimate, the paper's, the starting values, the end of a
        derivative-free search.

    Returns
    -------
    matplotlib.figure.Figure
    """
    m1 = np.asarray(m1, dtype=float)
    l1 = np.asarray(l1, dtype=float)
    cost = np.asarray(cost, dtype=float)
    fig = Figure(figsize=(FULL_WIDTH, 4.6), layout="constrained")
    ax = fig.add_subplot()
    ax.grid(False)
    levels = np.log10(np.maximum(cost, np.finfo(float).tiny))
    cs = ax.contourf(m1, l1, levels, levels=30, cmap="viridis")
    fig.colorbar(cs, ax=ax, label="log10 J [log10 N²·m²]")
    ax.plot(m1, np.sqrt(product / m1), "w--", lw=1.5, label=f"m1·l1² = {product:.4g} kg·m²")
    points = (
        (start, "s", COLORS[4], "start"),
        (paper_point, "^", COLORS[1], "paper's estimate"),
        (estimate, "o", "white", "our estimate (l1 held)"),
        (nelder_mead, "D", COLORS[5], "Nelder–Mead end"),
    )
    for point, marker, colour, label in points:
        if point is not None:
            ax.plot(*point, marker, color=colour, mec="k", ms=8, linestyle="none", label=label)
    ax.set_xlim(m1.min(), m1.max())
    ax.set_ylim(l1.min(), l1.max())
    ax.set_xlabel("m1 [kg]")
    ax.set_ylabel("l1 [m]")
    ax.set_title("J is flat along m1·l1² = const: m1 and l1 are not separately identifiable")
    legend_outside(ax, where="below")
    return fig


@styled
def plot_filter_sweep(
    cutoffs: Sequence[float],
    errors: Mapping[str, Sequence[float]],
    *,
    title: str = "Bias of the estimates against the filter cut-off",
    target: float | None = None,
) -> Figure:
    """Largest relative error [%] of the identifiable parameters against Ω_g, one line per variant.

    Parameters
    ----------
    cutoffs : sequence of float [rad/sample]
    errors : mapping label -> sequence of float [%]
        One curve per label (e.g. ``"M=100, paper filters"``), same length as ``cutoffs``.
    target : float [%], optional
        Draw a dashed horizontal line at this error (e.g. the 0.05 % goal).
    """
    fig = Figure(figsize=(FULL_WIDTH, panel_height(1, 3.0)), layout="constrained")
    ax = fig.add_subplot()
    x = np.asarray(cutoffs, dtype=float)
    for i, (label, values) in enumerate(errors.items()):
        ax.semilogy(
            x,
            np.abs(np.asarray(values, dtype=float)),
            color=COLORS[i % len(COLORS)],
            linestyle=LINESTYLES[i % len(LINESTYLES)],
            marker=MARKERS[i % len(MARKERS)],
            label=label,
        )
    if target is not None:
        ax.axhline(target, color="k", ls="--", lw=0.8, label=f"goal {target:g} %")
    ax.set_xlabel("cut-off Ω_g [rad/sample]")
    ax.set_ylabel("max |relative error| [%]")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    legend_outside(ax)
    return fig


@styled
def plot_histories_and_search(
    result,
    nm_history,
    names: Sequence[str],
    truth: Mapping[str, float],
    paper_evaluations: int | None = None,
) -> Figure:
    """A derivative-free search (top) and an input-error fit (bottom) over their evaluations.

    Parameters
    ----------
    result : InputErrorResult
        Its parameter history is drawn in the bottom panel.
    nm_history : array_like (n_evaluations, n_parameters)
        Every point a derivative-free search evaluated, columns ordered like ``names``.
    names : sequence of str
    truth : mapping name -> value
        Each parameter is divided by its true value.
    paper_evaluations : int, optional
        The paper's evaluation count, marked on the top panel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = Figure(figsize=(FULL_WIDTH, panel_height(2, 3.0)), layout="constrained")
    top, bottom = fig.subplots(2, 1)
    nm_history = np.asarray(nm_history, dtype=float)
    ref = np.array([truth[n] for n in names])
    evals = np.arange(1, nm_history.shape[0] + 1)
    for i, n in enumerate(names):
        top.plot(
            evals,
            nm_history[:, i] / ref[i],
            color=COLORS[i % len(COLORS)],
            linestyle=LINESTYLES[i % len(LINESTYLES)],
            lw=1.0,
            label=n,
        )
    if paper_evaluations:
        top.axvline(
            paper_evaluations, color="k", ls=":", lw=0.9, label=f"paper: ~{paper_evaluations}"
        )
    top.set_title(
        f"Nelder–Mead, all {len(names)} parameters free ({nm_history.shape[0]} evaluations)"
    )
    top.set_xlabel("evaluation [count]")
    top.set_ylabel("estimate / true value [–]")
    legend_outside(top)
    plot_parameter_histories(result, truth, ax=bottom)
    bottom.set_title("physid: least squares with the analytic Jacobian (l1 held)")
    fig.suptitle("How the parameter estimates evolve: derivative-free search vs least squares")
    return fig
