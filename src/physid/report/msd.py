"""Figures of the MSD study (Oueslati et al. 2011, section 5): convergence maps and ω0 traces.

Every function returns a `matplotlib.figure.Figure` built without pyplot (no global state, no
``plt.show``), so it works under any backend and in worker processes.

* `plot_convergence_maps` — convergence time to 2 % over SNR × Z, one panel per estimator
  (the paper's Figs. 5–6), from a `physid.analysis.montecarlo.SweepResult` or its summary.
* `plot_estimate_panels` — ω0 estimates against time, a grid of panels (Figs. 7–12, 14–15).
* `plot_measurement` — the measured position against the true one (Figs. 4, 13).
* `plot_tracking` — estimates of a jumping ω0 against the truth (Fig. 16).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

from ..errors import InputError
from .style import (
    BAND_COLOR,
    COLORS,
    FULL_WIDTH,
    TRUTH_STYLE,
    figure_legend,
    legend_outside,
    panel_height,
    styled,
)

__all__ = [
    "variant_label",
    "plot_convergence_maps",
    "plot_estimate_panels",
    "plot_measurement",
    "plot_tracking",
    "plot_trace_grid",
    "plot_tracking_panels",
]

METRIC_LABELS = {
    "t_first_hit": "first hit (paper's rule)",
    "t_settle": "settle (100 ms stretches ≥ 95 % within 2 %)",
}


def variant_label(cell: Mapping[str, Any]) -> str:
    """A short name for an estimator configuration: ``"algebraic T=0.05 s"``, ``"RLS λ=0.99"``."""
    method = cell.get("method")
    if method == "algebraic":
        window = cell.get("window")
        return "algebraic" + (f" T={window:g} s" if window is not None else "")
    if method == "rls":
        lam = cell.get("forgetting")
        return "RLS" + (f" λ={lam:g}" if lam is not None else "")
    return str(method)


def _cells_of(source) -> list[dict]:
    if hasattr(source, "summarize"):
        return list(source.summarize())
    if isinstance(source, Sequence):
        return [dict(c) for c in source]
    raise InputError(
        "plot_convergence_maps needs a SweepResult or its summarize() list; "
        f"got {type(source).__name__}."
    )


def _stat(entry, statistic: str) -> float:
    if not isinstance(entry, Mapping):
        return math.nan
    value = entry.get(statistic)
    return math.nan if value is None else float(value)


@styled
def plot_convergence_maps(
    source,
    *,
    metric: str = "t_first_hit",
    statistic: str = "median_censored",
    title: str | None = None,
    vmin: float | None = None,
    vmax: float | None = None,
) -> Figure:
    """Heat maps of the convergence time [s] over SNR (rows) × Z (columns), one per estimator.

    Parameters
    ----------
    source : SweepResult or list of dict
        A sweep over ``snr_db`` and ``ratio`` (and estimator settings), or its ``summarize()``.
    metric : str
        Output column to show, ``"t_first_hit"`` or ``"t_settle"``.
    statistic : str
        Statistic over the trials of a cell: ``"median_censored"`` (default; NaN = more than half
        the trials never reached 2 %), ``"median"``, ``"mean"``, ``"max"``.
    title : str, optional
    vmin, vmax : float, optional [s]
        Colour range (log scale); default the finite range of all panels.

    Returns
    -------
    matplotlib.figure.Figure
        Cells that never converged are grey and marked "never".
    """
    cells = _cells_of(source)
    if not cells or "snr_db" not in cells[0] or "ratio" not in cells[0]:
        raise InputError("plot_convergence_maps needs a sweep over the axes 'snr_db' and 'ratio'.")
    if metric not in cells[0]:
        raise InputError(
            f"metric {metric!r} is not a summarised output of this sweep; choose one of "
            f"{[k for k, v in cells[0].items() if isinstance(v, Mapping)]}."
        )
    variants: dict[str, list[dict]] = {}
    for c in cells:
        variants.setdefault(variant_label(c), []).append(c)
    snrs = sorted({c["snr_db"] for c in cells if c["snr_db"] is not None}, reverse=True)
    if any(c["snr_db"] is None for c in cells):
        snrs = [None, *snrs]
    ratios = sorted({c["ratio"] for c in cells})
    grids = {}
    for label, vc in variants.items():
        grid = np.full((len(snrs), len(ratios)), np.nan)
        for c in vc:
            grid[snrs.index(c["snr_db"]), ratios.index(c["ratio"])] = _stat(
                c.get(metric), statistic
            )
        grids[label] = grid
    finite = np.concatenate([g[np.isfinite(g) & (g > 0)] for g in grids.values()])
    lo = vmin if vmin is not None else (float(finite.min()) if finite.size else 1e-3)
    hi = vmax if vmax is not None else (float(finite.max()) if finite.size else 1.0)
    if hi <= lo:
        hi = lo * 10
    n = len(grids)
    fig = Figure(figsize=(4.2 * n + 1.0, 0.55 * len(snrs) + 2.2), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)[0]
    norm = LogNorm(vmin=lo, vmax=hi)
    image = None
    for ax, (label, grid) in zip(axes, grids.items(), strict=True):
        masked = np.ma.masked_invalid(np.where(grid > 0, grid, np.nan))
        cmap = _cmap()
        image = ax.imshow(masked, norm=norm, cmap=cmap, aspect="auto")
        for i in range(grid.shape[0]):
            for j in range(grid.shape[1]):
                v = grid[i, j]
                text = "never" if not np.isfinite(v) else f"{v:.3g}"
                ax.text(
                    j,
                    i,
                    text,
                    ha="center",
                    va="center",
                    fontsize=8,
                    color="black" if not np.isfinite(v) or norm(v) < 0.55 else "white",
                )
        ax.set_xticks(range(len(ratios)), [f"{z:g}" for z in ratios])
        ax.set_yticks(range(len(snrs)), ["clean" if s is None else f"{s:g}" for s in snrs])
        ax.set_xlabel("Z = ω1 / ω0 [–]")
        ax.set_ylabel("SNR [dB]")
        ax.grid(False)
        ax.set_title(label)
    if image is not None:
        fig.colorbar(image, ax=list(axes), label=f"time to 2 % [s] ({statistic.replace('_', ' ')})")
    fig.suptitle(title or f"Convergence time, {METRIC_LABELS.get(metric, metric)}", fontsize=11)
    return fig


def _cmap():
    from matplotlib import colormaps

    return colormaps["viridis_r"].with_extremes(bad="#d0d0d0")


@styled
def plot_estimate_panels(
    panels: Mapping[str, Sequence[tuple]],
    truth: float,
    *,
    tolerance: float = 0.02,
    ncols: int = 2,
    ylim_relative: float | None = 0.2,
    title: str | None = None,
    xlim: tuple[float, float] | None = None,
) -> Figure:
    """ω0 estimates against time in a grid of panels, with the truth and its ± tolerance band.

    Parameters
    ----------
    panels : mapping of str to sequence of tuples
        Panel title -> curves ``(label, t [s], values [rad/s])`` or ``(label, t, values, valid)``;
        invalid samples are not drawn.
    truth : float [rad/s]
    tolerance : float
        Half-width of the shaded band, relative (0.02 = 2 %).
    ncols : int
    ylim_relative : float or None
        The y range is truth × (1 ± ylim_relative); None lets matplotlib choose.
    title : str, optional
    xlim : (float, float), optional [s]

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not panels:
        raise InputError("plot_estimate_panels needs at least one panel.")
    n = len(panels)
    ncols = max(1, min(ncols, n))
    nrows = math.ceil(n / ncols)
    fig = Figure(figsize=(5.2 * ncols, 2.5 * nrows + 0.6), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax, (name, curves) in zip(axes[:n], panels.items(), strict=True):
        for curve in curves:
            label, t, values = curve[:3]
            values = np.asarray(values, dtype=float)
            if len(curve) > 3 and curve[3] is not None:
                values = np.where(np.asarray(curve[3], bool), values, np.nan)
            ax.plot(t, values, lw=0.9, label=label)
        ax.axhline(truth, color="black", lw=0.8, ls="--", label=f"true ω0 = {truth:.4g} rad/s")
        ax.axhspan(
            truth * (1 - tolerance),
            truth * (1 + tolerance),
            color="tab:green",
            alpha=0.12,
            label=f"± {tolerance:.0%}",
        )
        if ylim_relative is not None:
            ax.set_ylim(truth * (1 - ylim_relative), truth * (1 + ylim_relative))
        if xlim is not None:
            ax.set_xlim(*xlim)
        ax.set_title(name)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("ω0 estimate [rad/s]")
        legend_outside(ax, where="below")
    for ax in axes[n:]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


@styled
def plot_measurement(
    t, measured, true, *, t_max: float | None = None, title: str | None = None
) -> Figure:
    """Measured and true position against time (the paper's Figs. 4 and 13).

    Parameters
    ----------
    t : array_like (n_samples,) [s]
    measured, true : array_like (n_samples,) [m]
    t_max : float, optional [s]
        Show only ``t <= t_max`` (zoom).
    title : str, optional
    """
    t = np.asarray(t, float)
    keep = slice(None) if t_max is None else t <= t_max
    fig = Figure(figsize=(FULL_WIDTH, panel_height(1, 2.6)), layout="constrained")
    ax = fig.subplots()
    ax.plot(t[keep], np.asarray(measured, float)[keep], lw=0.8, color=COLORS[0], label="measured x̃")
    ax.plot(t[keep], np.asarray(true, float)[keep], lw=1.4, color="black", ls="--", label="true x")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("position [m]")
    legend_outside(ax)
    if title:
        ax.set_title(title)
    return fig


@styled
def plot_tracking(
    t,
    truth,
    curves: Sequence[tuple],
    jump_times: Sequence[float],
    *,
    tolerance: float = 0.02,
    title: str | None = None,
) -> Figure:
    """Estimates of a time-varying ω0 against its true staircase (the paper's Fig. 16).

    Parameters
    ----------
    t : array_like (n_samples,) [s]
    truth : array_like (n_samples,) [rad/s]
        True ω0 at each sample.
    curves : sequence of tuples
        ``(label, t, values)`` or ``(label, t, values, valid)``.
    jump_times : sequence of float [s]
    tolerance : float
        Relative half-width of the band around the truth.
    title : str, optional
    """
    t = np.asarray(t, float)
    truth = np.asarray(truth, float)
    fig = Figure(figsize=(8.0, 3.4), layout="constrained")
    ax = fig.subplots()
    ax.fill_between(
        t,
        truth * (1 - tolerance),
        truth * (1 + tolerance),
        color="tab:green",
        alpha=0.15,
        label=f"truth ± {tolerance:.0%}",
        step="post",
    )
    ax.plot(t, truth, color="black", lw=1.0, ls="--", label="true ω0")
    for curve in curves:
        label, tc, values = curve[:3]
        values = np.asarray(values, float)
        if len(curve) > 3 and curve[3] is not None:
            values = np.where(np.asarray(curve[3], bool), values, np.nan)
        ax.plot(tc, values, lw=0.9, label=label)
    for tj in jump_times:
        ax.axvline(tj, color="grey", lw=0.6, ls=":")
    lo, hi = float(np.min(truth)), float(np.max(truth))
    pad = 0.25 * (hi - lo) + 0.1 * hi
    ax.set_ylim(lo - pad, hi + pad)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("ω0 [rad/s]")
    legend_outside(ax)
    if title:
        ax.set_title(title)
    return fig


def _masked(values, valid):
    values = np.asarray(values, dtype=float)
    if valid is not None:
        values = np.where(np.asarray(valid, bool), values, np.nan)
    return values


@styled
def plot_trace_grid(
    rows: Sequence[tuple[str, Sequence[tuple]]],
    truth: float,
    *,
    tolerance: float = 0.02,
    ylim_relative: float | None = 0.2,
    title: str | None = None,
) -> Figure:
    """Small multiples of ω0 estimates: one panel per curve, so no line hides another.

    Parameters
    ----------
    rows : sequence of (row label, sequence of (panel title, t [s], ω0 [rad/s], valid or None))
        One row of panels per entry (e.g. one SNR), one column per estimator.
    truth : float [rad/s]
        Drawn dashed in every panel with its ± tolerance band.
    tolerance : float
        Relative half-width of the band (0.02 = 2 %).
    ylim_relative : float or None
        Every panel shows truth × (1 ± ylim_relative); None: matplotlib's limits.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not rows:
        raise InputError("plot_trace_grid needs at least one row of panels.")
    nrows, ncols = len(rows), max(len(panels) for _, panels in rows)
    fig = Figure(figsize=(FULL_WIDTH, panel_height(nrows, 2.1, 1.2)), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, sharex=True, sharey=True)
    for i, (row_label, panels) in enumerate(rows):
        for j in range(ncols):
            ax = axes[i, j]
            if j >= len(panels):
                ax.set_visible(False)
                continue
            name, t, values, valid = panels[j]
            ax.axhspan(
                truth * (1 - tolerance),
                truth * (1 + tolerance),
                color=BAND_COLOR,
                alpha=0.18,
                label=f"true ω0 ± {tolerance:.0%}",
            )
            ax.axhline(truth, **TRUTH_STYLE, label=f"true ω0 = {truth:.4g} rad/s")
            ax.plot(
                t, _masked(values, valid), color=COLORS[j % len(COLORS)], lw=1.0, label="estimate"
            )
            if ylim_relative is not None:
                ax.set_ylim(truth * (1 - ylim_relative), truth * (1 + ylim_relative))
            ax.set_title(f"{name}, {row_label}" if row_label else name)
            if i == nrows - 1:
                ax.set_xlabel("t [s]")
            if j == 0:
                ax.set_ylabel("ω0 [rad/s]")
    figure_legend(fig, axes[-1, 0], ncol=3)
    if title:
        fig.suptitle(title)
    return fig


@styled
def plot_tracking_panels(
    t,
    truth,
    curves: Sequence[tuple],
    jump_times: Sequence[float],
    *,
    tolerance: float = 0.02,
    title: str | None = None,
) -> Figure:
    """A jumping ω0 and its estimates, one panel per estimator (small multiples).

    Parameters
    ----------
    t : array_like (n_samples,) [s]
    truth : array_like (n_samples,) [rad/s]
        True ω0 at each sample (a staircase).
    curves : sequence of tuples
        ``(label, t, values)`` or ``(label, t, values, valid)``, one panel each.
    jump_times : sequence of float [s]
    tolerance : float
        Relative half-width of the band around the truth.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = np.asarray(t, float)
    truth = np.asarray(truth, float)
    n = len(curves)
    fig = Figure(figsize=(FULL_WIDTH, panel_height(n, 1.5, 1.3)), layout="constrained")
    axes = fig.subplots(n, 1, squeeze=False, sharex=True, sharey=True)[:, 0]
    lo, hi = float(np.min(truth)), float(np.max(truth))
    pad = 0.25 * (hi - lo) + 0.1 * hi
    for k, (ax, curve) in enumerate(zip(axes, curves, strict=True)):
        label, tc, values = curve[:3]
        valid = curve[3] if len(curve) > 3 else None
        ax.fill_between(
            t,
            truth * (1 - tolerance),
            truth * (1 + tolerance),
            color=BAND_COLOR,
            alpha=0.2,
            step="post",
            label=f"true ω0 ± {tolerance:.0%}",
        )
        ax.plot(t, truth, **TRUTH_STYLE, label="true ω0")
        ax.plot(tc, _masked(values, valid), color=COLORS[k % len(COLORS)], lw=1.0, label="estimate")
        for tj in jump_times:
            ax.axvline(tj, color="grey", lw=0.6, ls=":")
        ax.set_ylim(lo - pad, hi + pad)
        ax.set_ylabel("ω0 [rad/s]")
        ax.set_title(label, loc="left")
    axes[-1].set_xlabel("t [s]")
    figure_legend(fig, axes[-1], ncol=3)
    if title:
        fig.suptitle(title)
    return fig
