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

__all__ = [
    "plot_parameter_histories",
    "plot_valley",
    "plot_residuals",
    "plot_input_error",
    "plot_filter_sweep",
]

_COLORS = (
    "tab:red",
    "tab:green",
    "tab:blue",
    "gold",
    "tab:purple",
    "tab:brown",
    "tab:pink",
    "tab:gray",
)


def _reference(result, truth: Mapping[str, float] | None) -> np.ndarray:
    names = result.parameter_names
    if truth is None:
        return np.array([result.parameters[n] for n in names], dtype=float)
    return np.array([truth.get(n, result.parameters[n]) for n in names], dtype=float)


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
        fig = Figure(figsize=(7.0, 3.8), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    ref = _reference(result, truth)
    hist = np.asarray(result.history, dtype=float)
    evals = np.arange(1, hist.shape[0] + 1)
    for i, name in enumerate(result.parameter_names):
        style = "--" if name in result.fixed else "-"
        label = f"{name} (held)" if name in result.fixed else name
        ax.plot(
            evals,
            hist[:, i] / ref[i],
            style,
            color=_COLORS[i % len(_COLORS)],
            marker=".",
            label=label,
        )
    if paper_evaluations:
        ax.axvline(paper_evaluations, color="k", lw=0.8, ls=":")
        ax.text(
            paper_evaluations,
            ax.get_ylim()[1],
            f" paper: ~{paper_evaluations}",
            va="top",
            fontsize=8,
        )
    ax.set_xlabel("residual evaluation")
    ax.set_ylabel("estimate / " + ("true value" if truth is not None else "final value"))
    ax.set_title(f"Parameter histories ({hist.shape[0]} evaluations, {result.njev} Jacobians)")
    ax.grid(True, alpha=0.3)
    ax.legend(ncol=4, fontsize=8)
    return fig


def plot_residuals(result, *, ax=None) -> Figure:
    """Equation residuals ``τ̂ − τ^f`` [N·m] per joint against time at the estimate."""
    if ax is None:
        fig = Figure(figsize=(7.0, 3.2), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    e = np.asarray(result.residuals)
    for j in range(e.shape[1]):
        rms = float(np.sqrt(np.mean(e[:, j] ** 2)))
        ax.plot(
            result.t,
            e[:, j],
            color=_COLORS[j % len(_COLORS)],
            lw=0.8,
            label=f"joint {j + 1} (rms {rms:.3g})",
        )
    ax.set_xlabel("t [s]")
    ax.set_ylabel("τ̂ − τ$^f$ [N·m]")
    ax.set_title(f"Residuals at the estimate, J = {result.cost:.4g}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def plot_input_error(result, truth: Mapping[str, float] | None = None) -> Figure:
    """Parameter histories (top) and residuals (bottom) of an input-error fit."""
    fig = Figure(figsize=(7.5, 6.5), layout="constrained")
    top, bottom = fig.subplots(2, 1)
    plot_parameter_histories(result, truth, ax=top)
    plot_residuals(result, ax=bottom)
    return fig


def plot_valley(
    m1,
    l1,
    cost,
    *,
    product: float,
    estimate: tuple[float, float] | None = None,
    paper_point: tuple[float, float] | None = None,
    start: tuple[float, float] | None = None,
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
    estimate, paper_point, start : (m1, l1), optional
        Points to mark: our estimate, the paper's, the starting values.

    Returns
    -------
    matplotlib.figure.Figure
    """
    m1 = np.asarray(m1, dtype=float)
    l1 = np.asarray(l1, dtype=float)
    cost = np.asarray(cost, dtype=float)
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = fig.add_subplot()
    levels = np.log10(np.maximum(cost, np.finfo(float).tiny))
    cs = ax.contourf(m1, l1, levels, levels=30, cmap="viridis")
    fig.colorbar(cs, ax=ax, label="log10 J")
    ax.plot(m1, np.sqrt(product / m1), "w--", lw=1.5, label=f"m1·l1² = {product:.4g} kg·m²")
    if start is not None:
        ax.plot(*start, "s", color="orange", label="start")
    if paper_point is not None:
        ax.plot(*paper_point, "^", color="red", label="paper's estimate")
    if estimate is not None:
        ax.plot(*estimate, "o", color="white", mec="k", label="our estimate (l1 held)")
    ax.set_xlim(m1.min(), m1.max())
    ax.set_ylim(l1.min(), l1.max())
    ax.set_xlabel("m1 [kg]")
    ax.set_ylabel("l1 [m]")
    ax.set_title(
        "J is flat along m1·l1² = const: m1 and l1 are not separately identifiable", fontsize=10
    )
    ax.legend(fontsize=8, loc="upper right")
    return fig


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
    fig = Figure(figsize=(6.4, 3.8), layout="constrained")
    ax = fig.add_subplot()
    x = np.asarray(cutoffs, dtype=float)
    for i, (label, values) in enumerate(errors.items()):
        ax.semilogy(
            x,
            np.abs(np.asarray(values, dtype=float)),
            "o-",
            color=_COLORS[i % len(_COLORS)],
            label=label,
        )
    if target is not None:
        ax.axhline(target, color="k", ls="--", lw=0.8, label=f"goal {target:g} %")
    ax.set_xlabel("cut-off Ω_g [rad/sample]")
    ax.set_ylabel("max |relative error| [%]")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig
