"""Figures of the input-design analysis: log10 K against Z (the paper's Figs. 2 and 3)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .style import FULL_WIDTH, legend_outside, panel_height, styled

__all__ = ["plot_input_design"]


@styled
def plot_input_design(result, ax=None, *, relative: bool = False) -> Figure:
    """log10 K(Z) for each forgetting factor (Fig. 2) and, at λ = 1, for each horizon k (Fig. 3).

    Parameters
    ----------
    result : InputDesignResult
        From `physid.analysis.input_design.design_input`.
    ax : matplotlib Axes, optional
        Draw only the λ panel there (its figure is returned).
    relative : bool
        Draw the λ panel as K(Z, λ) / K(Z, λ = 1) (or over the smallest K at each Z when λ = 1
        is not among the forgetting factors): curves that lie on top of each other in log10 K
        become separate lines, and which λ is best at each Z reads directly.

    Returns
    -------
    matplotlib.figure.Figure
        Optimal ratios are marked with dots on each curve.
    """
    if ax is not None:
        fig, axes = ax.figure, [ax]
    else:
        fig = Figure(figsize=(FULL_WIDTH, panel_height(1, 3.0)), layout="constrained")
        axes = list(fig.subplots(1, 2))
    Z = result.ratio
    panel = axes[0]
    K = np.asarray(result.variance_factor, dtype=float)
    if relative:
        ref = K[list(result.forgetting).index(1.0)] if 1.0 in result.forgetting else K.min(0)
        for j, lam in enumerate(result.forgetting):
            panel.plot(Z, K[j] / ref, lw=1.3, label=f"λ = {lam:g}")
        panel.set_yscale("log")
        panel.set_ylabel("K(λ) / K(λ = 1) [–]")
        panel.set_title(f"Forgetting factor, relative to λ = 1 (k = {result.samples})")
    else:
        for j, lam in enumerate(result.forgetting):
            (line,) = panel.plot(Z, np.log10(K[j]), lw=1.2, label=f"λ = {lam:g}")
            z_opt = result.optimal_ratio[j]
            panel.plot(
                z_opt, np.log10(result.optimal_variance_factor[j]), "o", color=line.get_color()
            )
        panel.set_title(f"Forgetting factor (k = {result.samples}, m = {result.init_samples})")
        panel.set_ylabel("log10 K [log10 s⁻⁴]")
    panel.set_xlabel("Z = ω1 / ω0 [–]")
    legend_outside(panel, where="below")
    if len(axes) > 1:
        panel = axes[1]
        for h, curve, z_opt in zip(
            result.horizons,
            result.horizon_variance_factor,
            result.horizon_optimal_ratio,
            strict=True,
        ):
            (line,) = panel.plot(Z, np.log10(curve), lw=1.2, label=f"k = {h}")
            panel.axvline(z_opt, color=line.get_color(), lw=0.6, ls=":")
        panel.set_title(f"Horizon, λ = 1 (T_s = {result.sample_period * 1e3:g} ms)")
        panel.set_xlabel("Z = ω1 / ω0 [–]")
        panel.set_ylabel("log10 K [log10 s⁻⁴]")
        legend_outside(panel, where="below")
    return fig
