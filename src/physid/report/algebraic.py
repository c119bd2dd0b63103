"""Figures of the algebraic estimator: estimates against time with the invalid windows shaded."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

__all__ = ["plot_algebraic"]


def _spans(mask: np.ndarray):
    """(start, stop) index pairs of the runs of True in ``mask``."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1, strict=True)


def plot_algebraic(
    result, names: Sequence[str] | None = None, truth: Mapping[str, float] | None = None
):
    """Plot per-window estimates against the window end time ``t0``.

    Parameters
    ----------
    result : AlgebraicResult
    names : sequence of str, optional
        Series to plot (default: the estimated coefficients, plus ω0 and ζ for the MSD).
    truth : mapping name -> value, optional
        Reference values drawn as dashed lines.

    Returns
    -------
    matplotlib.figure.Figure
        One axis per series; grey bands mark windows that do not exist or failed the determinant
        guard, the solid line the final estimate (``result.parameters``: pooled least squares
        over the valid windows by default, or their median with ``final="median"``).
    """
    from matplotlib.figure import Figure

    if names is None:
        names = list(result.names)
        if "natural_frequency" in result.parameters:
            names += ["natural_frequency", "damping_ratio"]
    fig = Figure(figsize=(8, 1.9 * len(names) + 0.6), layout="constrained")
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    t = result.t
    invalid = ~np.asarray(result.valid, dtype=bool)
    for ax, name in zip(axes, names, strict=True):
        series = result.series(name)
        shown = np.where(result.valid, series, np.nan)
        ax.plot(t, shown, lw=0.9, label="valid windows")
        finite = np.isfinite(shown)
        if finite.any():
            lo, hi = np.percentile(shown[finite], [1, 99])
            pad = 0.5 * (hi - lo) + 1e-12 * max(abs(lo), abs(hi), 1.0)
            ax.set_ylim(lo - pad, hi + pad)
        for a, b in _spans(invalid):
            ax.axvspan(t[a], t[min(b + 1, t.size - 1)], color="0.85", lw=0)
        final = result.parameters.get(name)
        if final is not None and np.isfinite(final):
            ax.axhline(final, color="C1", lw=1, label=f"final {final:.6g}")
        if truth and name in truth:
            ax.axhline(truth[name], color="k", ls="--", lw=0.8, label=f"true {truth[name]:.6g}")
        ax.set_ylabel(name)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("window end t0 [s]")
    axes[0].set_title(
        f"Algebraic estimator (T = {result.window:g} s, μ = {result.mu}, {result.integration}, "
        f"block {result.block}); grey: invalid windows ({1 - result.valid_fraction:.0%})"
    )
    return fig
