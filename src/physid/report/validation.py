"""Figures and a small HTML page for `physid.analysis.validation.ValidationReport`."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

__all__ = ["write_validation_plots", "plot_comparison", "plot_residual"]


def plot_comparison(t, channels, title: str):
    """Measured against predicted signals, one axis per channel.

    Parameters
    ----------
    t : ndarray, shape (n_samples,) [s]
    channels : dict
        name -> (measured, predicted), each shape (n_samples,).
    title : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 1.9 * len(channels) + 0.6), layout="constrained")
    axes = fig.subplots(len(channels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (name, (y, y_hat)) in zip(axes, channels.items(), strict=True):
        ax.plot(t, y, lw=0.9, label="measured")
        ax.plot(t, y_hat, lw=0.9, ls="--", label="model")
        ax.set_ylabel(name)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(title)
    return fig


def plot_residual(residual: dict):
    """Residual autocorrelation and cross-correlation with the 99 % band (MATLAB ``resid``).

    Parameters
    ----------
    residual : dict
        From `physid.analysis.validation.residual_analysis`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    n_panels = 1 + (1 if residual.get("cross_correlation") else 0)
    fig = Figure(figsize=(8, 2.4 * n_panels + 0.4), layout="constrained")
    axes = fig.subplots(n_panels, 1, squeeze=False)[:, 0]
    band = residual["band"]
    lags = np.asarray(residual["lags"])
    max_lag = int(lags.max())
    for a in residual["autocorrelation"]:
        axes[0].stem(np.arange(max_lag + 1), a, basefmt=" ")
    axes[0].set_title("autocorrelation of the residual")
    if n_panels == 2:
        for c in residual["cross_correlation"]:
            axes[1].stem(lags, c, basefmt=" ")
        axes[1].set_title("cross-correlation of the residual with the input")
    for ax in axes:
        ax.axhspan(-band, band, color="0.85", lw=0, label="99 % band")
        ax.set_xlabel("lag [samples]")
        ax.legend(loc="upper right", fontsize="small")
    fig.suptitle(residual.get("verdict", ""), fontsize="small")
    return fig


def write_validation_plots(report, out_dir) -> dict[str, str]:
    """PNG figures and ``index.html`` of a validation report.

    Parameters
    ----------
    report : ValidationReport
    out_dir : str or Path
        Folder (created if missing); files are written atomically.

    Returns
    -------
    dict
        name -> path of each file written.
    """
    from .._paths import atomic_write
    from .style import save_figure

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = {}
    s = report.series
    if "inverse" in s:
        t, ch = s["inverse"]
        figures["inverse_model"] = plot_comparison(t, ch, "(a) inverse model (filtered signals)")
    if "output" in s:
        t, ch = s["output"]
        figures["output_error"] = plot_comparison(t, ch, "(b) output error (simulation)")
    if "residual" in s:
        figures["residual"] = plot_residual(s["residual"])
    written = {}
    for name, fig in figures.items():
        path = out / f"{name}.png"
        save_figure(fig, path)
        written[name] = str(path)
    rows = "".join(
        f"<li>{html.escape(line.strip())}</li>" for line in report.summary().splitlines()[1:]
    )
    imgs = "".join(f'<h2>{html.escape(n)}</h2><img src="{n}.png" alt="{n}">' for n in figures)
    page = (
        "<!doctype html><html><head><meta charset='utf-8'><title>physid validation</title>"
        "</head><body><h1>Validation on held-out data</h1><ul>"
        f"{rows}</ul>{imgs}</body></html>\n"
    )
    atomic_write(out / "index.html", lambda fh: fh.write(page))
    written["index"] = str(out / "index.html")
    return written
