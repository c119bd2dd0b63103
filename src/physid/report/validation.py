"""Figures and a small HTML page for `physid.analysis.validation.ValidationReport`."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .style import (
    COLORS,
    DROPPED_LABEL,
    FULL_WIDTH,
    legend_outside,
    panel_height,
    shade_dropped,
    styled,
)

__all__ = ["write_validation_plots", "plot_comparison", "plot_residual", "channel_labels"]


def _fit(y, y_hat) -> float:
    ok = np.isfinite(y) & np.isfinite(y_hat)
    if ok.sum() < 2:
        return float("nan")
    spread = float(np.linalg.norm(y[ok] - y[ok].mean()))
    return 100.0 * (1.0 - float(np.linalg.norm(y[ok] - y_hat[ok])) / spread) if spread else np.nan


@styled
def plot_comparison(t, channels, title: str, *, labels=None):
    """Measured, model and residual in separate panels per channel (MATLAB ``compare``).

    Samples that are NaN (dropped near rest) are drawn as gaps and shaded, with the legend entry
    `DROPPED_LABEL`; the model's legend entry carries its fit
    ``100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖)`` over the samples shown.

    Parameters
    ----------
    t : ndarray, shape (n_samples,) [s]
    channels : dict
        name -> (measured, predicted), each shape (n_samples,); NaN where a sample was dropped.
    title : str
    labels : dict, optional
        name -> axis label with the user's column and unit (``"u = Force [N]"``); default the
        name.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    labels = dict(labels or {})
    t = np.asarray(t, dtype=float)
    n = len(channels)
    fig = Figure(
        figsize=(FULL_WIDTH, panel_height(n, 2.9, 0.9)),
        layout="constrained",
    )
    grid = fig.add_gridspec(2 * n, 1, height_ratios=[2.2, 1.0] * n)
    first = None
    for k, (name, (y, y_hat)) in enumerate(channels.items()):
        y, y_hat = np.asarray(y, dtype=float), np.asarray(y_hat, dtype=float)
        top = fig.add_subplot(grid[2 * k], sharex=first)
        first = first or top
        low = fig.add_subplot(grid[2 * k + 1], sharex=first)
        dropped = ~(np.isfinite(y) & np.isfinite(y_hat))
        for ax in (top, low):
            shade_dropped(ax, t, dropped)
        top.plot(t, y, color=COLORS[0], lw=1.1, label="measured")
        top.plot(
            t, y_hat, color=COLORS[1], lw=1.0, ls="--", label=f"model (fit {_fit(y, y_hat):.2f} %)"
        )
        low.plot(t, y - y_hat, color=COLORS[2], lw=0.9, label="residual (measured − model)")
        low.axhline(0.0, color="0.4", lw=0.6)
        label = labels.get(name, name)
        top.set_ylabel(label)
        unit = label[label.rfind("[") :] if label.endswith("]") else ""
        low.set_ylabel(f"residual {unit}".strip())
        top.tick_params(labelbottom=False)
        legend_outside(top)
        legend_outside(low)
    low.set_xlabel("t [s]")
    fig.suptitle(title)
    return fig


@styled
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
    fig = Figure(figsize=(FULL_WIDTH, panel_height(n_panels, 2.4, 0.8)), layout="constrained")
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
    import textwrap

    fig.suptitle(textwrap.fill(residual.get("verdict", ""), 110), fontsize="small")
    return fig


def channel_labels(recording) -> dict[str, str]:
    """Axis labels in the user's words: ``"u = Force [N]"`` (mapped column) or ``"x [m]"``.

    Parameters
    ----------
    recording : Recording or None

    Returns
    -------
    dict
        channel -> label (empty without a recording).
    """
    if recording is None:
        return {}
    meta = dict(getattr(recording, "metadata", None) or {})
    sources = dict(meta.get("channel_map") or {})
    out = {}
    for name, unit in zip(recording.names, recording.units, strict=True):
        source = sources.get(name)
        text = f"{name} = {source}" if source and str(source) != name else name
        out[name] = f"{text} [{unit}]" if unit else text
    return out


def write_validation_plots(report, out_dir, *, recording=None) -> dict[str, str]:
    """PNG figures and ``index.html`` of a validation report.

    Parameters
    ----------
    report : ValidationReport
    out_dir : str or Path
        Folder (created if missing); files are written atomically.
    recording : Recording, optional
        The held-out recording: its channel map and units label the axes.

    Returns
    -------
    dict
        name -> path of each file written.
    """
    from .._paths import atomic_write
    from .style import save_figure

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    labels = channel_labels(recording)
    figures, captions = {}, {}
    s = report.series
    if "inverse" in s:
        t, ch = s["inverse"]
        figures["inverse_model"] = plot_comparison(
            t, ch, "(a) inverse model (filtered signals)", labels=labels
        )
        captions["inverse_model"] = (
            "(a) The input (or torque) the model computes from the measured motion, against the "
            "measured one, both filtered as in the fit; below, their difference. Grey spans: "
            f"samples {DROPPED_LABEL} (drawn as gaps, not as zero)."
        )
    if "output" in s:
        t, ch = s["output"]
        figures["output_error"] = plot_comparison(
            t, ch, "(b) output error (simulation)", labels=labels
        )
        captions["output_error"] = (
            "(b) The output simulated from the measured input against the measured output; "
            "below, the residual. The fit is MATLAB compare's."
        )
    if "residual" in s:
        figures["residual"] = plot_residual(s["residual"])
        captions["residual"] = (
            "(c) Autocorrelation of the residual and its cross-correlation with the input; grey "
            "band: 99 % of a white residual independent of the input."
        )
    written = {}
    for name, fig in figures.items():
        path = out / f"{name}.png"
        save_figure(fig, path)
        written[name] = str(path)
    page = _page(report, figures, captions)
    atomic_write(out / "index.html", lambda fh: fh.write(page))
    written["index"] = str(out / "index.html")
    return written


def _page(report, figures, captions) -> str:
    esc = html.escape
    rows = []
    for k, v in report.relative_error.items():
        rows.append(("(a) inverse model, relative error", esc(k), f"{v:.4g}"))
    for k, v in report.fit_percent.items():
        rows.append(("(b) output error, fit", esc(k), f"{v:.2f} %"))
    table = "".join(f"<tr><td>{a}</td><td>{b}</td><td>{c}</td></tr>" for a, b, c in rows)
    verdict = esc(report.residual.get("verdict", "")) if report.residual else ""
    notes = "".join(f"<li>{esc(n)}</li>" for n in report.notes)
    body = "".join(
        f"<figure><img src='{n}.png' alt='{esc(captions.get(n, n))}'>"
        f"<figcaption>{esc(captions.get(n, ''))}</figcaption></figure>"
        for n in figures
    )
    return (
        "<!doctype html><html><head><meta charset='utf-8'><meta name='viewport' "
        "content='width=device-width, initial-scale=1'><title>physid validation</title><style>"
        "body{font-family:system-ui,sans-serif;max-width:62rem;margin:1rem auto;padding:0 1rem;"
        "line-height:1.45}img{max-width:100%;height:auto}table{border-collapse:collapse}"
        "td{padding:.2rem .8rem .2rem 0;border-bottom:1px solid #ddd}"
        ".verdict{padding:.6rem .8rem;background:#f3f6fa;border-left:4px solid #0072B2}"
        "figcaption{font-size:.9em;color:#444;overflow-wrap:anywhere}</style></head><body>"
        "<h1>Validation on held-out data</h1>"
        f"<table>{table}</table>"
        f"<p class='verdict'><b>(c) residual tests:</b> {verdict}</p>"
        f"{body}<h2>How each number was computed</h2><ul>{notes}</ul></body></html>\n"
    )
