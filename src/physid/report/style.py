"""One figure style for every physid figure: the report, the sweeps and ``result.plot()``.

* **Sizes**: `FULL_WIDTH` (a report column, inches) and `panel_height`; one `DPI` for every PNG.
* **Fonts and lines**: `RC` (matplotlib rc parameters), applied by `styled` around a drawing
  function, so a figure drawn anywhere (a worker process, a notebook) looks the same.
* **Colours**: `COLORS` is the Okabe–Ito palette (distinct for the common colour-vision
  deficiencies); `LINESTYLES` and `MARKERS` add a second cue so that curves stay distinct in grey.
  `series_style(i)` gives the i-th curve's colour, dash and marker; the property cycle uses the
  same order.
* **Legends outside the data**: `legend_outside(ax)` puts a legend beside or below the axes.
* **One writer**: `save_figure(fig, path)` (one dpi, one bounding box, atomic), also used for an
  in-memory PNG with `figure_png(fig)`.
* **Robust limits**: `robust_limits(values, truth=...)` sets a y range by the converged part of a
  trace (percentiles of its second half), never by a start-up transient.

Example
-------
>>> from matplotlib.figure import Figure
>>> @styled
... def line():
...     fig = Figure(figsize=(FULL_WIDTH, panel_height()))
...     ax = fig.add_subplot()
...     ax.plot([0, 1], [0, 1], label="a"); ax.set_xlabel("t [s]"); ax.set_ylabel("x [m]")
...     legend_outside(ax)
...     return fig
>>> png = figure_png(line())
>>> png[:4] == b"\\x89PNG"
True
"""

from __future__ import annotations

import functools
import io
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

__all__ = [
    "DPI",
    "FULL_WIDTH",
    "COLORS",
    "LINESTYLES",
    "MARKERS",
    "TRUTH_STYLE",
    "FINAL_STYLE",
    "BAND_COLOR",
    "RC",
    "panel_height",
    "series_style",
    "styled",
    "legend_outside",
    "figure_legend",
    "robust_limits",
    "figure_png",
    "save_figure",
    "describe_figure",
    "final_value",
    "unit_of",
    "DROPPED_LABEL",
    "shade_dropped",
]

#: Resolution of every PNG physid writes [dots per inch].
DPI = 110
#: Width of a full-width report figure [in] (about 1000 px at `DPI`).
FULL_WIDTH = 9.0

#: Okabe & Ito (2008), "Color universal design": distinct for protan, deutan and tritan vision.
COLORS = (
    "#0072B2",  # blue
    "#D55E00",  # vermillion
    "#009E73",  # bluish green
    "#CC79A7",  # reddish purple
    "#E69F00",  # orange
    "#56B4E9",  # sky blue
    "#000000",  # black
    "#882255",  # wine (Tol's muted palette; Okabe–Ito's yellow is too pale on white)
)
#: A second cue for grey printing: each curve also gets its own dash pattern ...
LINESTYLES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1)), (0, (3, 1, 1, 1, 1, 1)), "-", "--")
#: ... and, where points are drawn, its own marker.
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
#: The true value: thin black dashes.
TRUTH_STYLE = {"color": "black", "linestyle": "--", "linewidth": 1.0}
#: The final estimate: a dotted line in the first series colour.
FINAL_STYLE = {"color": COLORS[1], "linestyle": ":", "linewidth": 1.4}
#: A tolerance band (e.g. ± 2 % around the truth).
BAND_COLOR = "#009E73"

RC: dict[str, Any] = {
    "font.size": 10.0,
    "axes.titlesize": 10.5,
    "axes.labelsize": 10.0,
    "xtick.labelsize": 9.0,
    "ytick.labelsize": 9.0,
    "legend.fontsize": 8.5,
    "figure.titlesize": 11.5,
    "lines.linewidth": 1.3,
    "axes.linewidth": 0.8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "legend.frameon": False,
    "savefig.dpi": DPI,
    "figure.dpi": DPI,
}

F = TypeVar("F", bound=Callable[..., Any])


def _cycler():
    from cycler import cycler

    n = len(COLORS)
    return cycler(color=list(COLORS)) + cycler(linestyle=list(LINESTYLES[:n]))


def panel_height(rows: int = 1, per_row: float = 2.6, extra: float = 0.9) -> float:
    """Height [in] of a figure with ``rows`` panels stacked (title and legend room included)."""
    return extra + per_row * rows


def series_style(i: int) -> dict[str, Any]:
    """Colour, dash pattern and marker of the ``i``-th curve (wraps around)."""
    n = len(COLORS)
    return {"color": COLORS[i % n], "linestyle": LINESTYLES[i % n], "marker": MARKERS[i % n]}


def styled(function: F) -> F:
    """Decorator: run a figure-drawing function under `RC` and the colour/dash cycle."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        import matplotlib

        with matplotlib.rc_context({**RC, "axes.prop_cycle": _cycler()}):
            return function(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def legend_outside(ax, *, where: str = "right", ncol: int | None = None, **kwargs):
    """A legend outside the data area of ``ax``: ``where`` = ``"right"`` or ``"below"``.

    Returns the legend (None when nothing is labelled).
    """
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    if where == "below":
        return ax.legend(
            handles,
            labels,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.22),
            ncol=ncol or min(4, len(labels)),
            borderaxespad=0.0,
            **kwargs,
        )
    return ax.legend(
        handles,
        labels,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        ncol=ncol or 1,
        borderaxespad=0.0,
        **kwargs,
    )


def figure_legend(fig, ax, *, ncol: int | None = None, **kwargs):
    """One legend for a grid of panels, below them (outside every data area).

    Uses the labelled artists of ``ax`` (all panels draw the same kinds of line).
    """
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    return fig.legend(
        handles, labels, loc="outside lower center", ncol=ncol or min(4, len(labels)), **kwargs
    )


def robust_limits(
    values,
    *,
    truth: float | None = None,
    final: float | None = None,
    converged_fraction: float = 0.5,
    percentiles: tuple[float, float] = (1.0, 99.0),
    pad: float = 0.25,
) -> tuple[float, float] | None:
    """y limits from the converged part of a trace, keeping the truth and final value in view.

    Parameters
    ----------
    values : array_like (n,)
        The trace; non-finite samples are ignored.
    truth, final : float, optional
        Values that must stay inside the limits (the true value, the final estimate).
    converged_fraction : float
        The last fraction of the finite samples that counts as converged (0.5: the second half).
    percentiles : (float, float)
        Percentiles of the converged part that set the range (robust against spikes).
    pad : float
        Margin added on each side, as a fraction of the range.

    Returns
    -------
    (low, high) or None
        None when there is no finite sample.
    """
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    tail = v[int(v.size * (1.0 - converged_fraction)) :]
    low, high = np.percentile(tail, percentiles)
    keep = [x for x in (truth, final) if x is not None and np.isfinite(x)]
    low, high = min([low, *keep]), max([high, *keep])
    span = high - low
    scale = max(abs(low), abs(high), 1e-12)
    span = max(span, 1e-3 * scale)
    return float(low - pad * span), float(high + pad * span)


def final_value(result, name: str, values=None) -> float | None:
    """The final estimate of ``name`` in a result: ``parameters``, then ``derived``, then the
    last finite value of ``values``."""
    for where in ("parameters", "derived"):
        mapping = getattr(result, where, None) or {}
        value = mapping.get(name) if hasattr(mapping, "get") else None
        if value is not None and np.isfinite(value):
            return float(value)
    if values is not None:
        v = np.asarray(values, dtype=float)
        v = v[np.isfinite(v)]
        if v.size:
            return float(v[-1])
    return None


def unit_of(result, name: str) -> str:
    """``" [unit]"`` of ``name`` from ``result.units``; empty when the result gives none."""
    units = getattr(result, "units", None) or {}
    unit = units.get(name) if hasattr(units, "get") else None
    return f" [{unit}]" if unit else ""


def figure_png(fig) -> bytes:
    """The PNG bytes of ``fig`` at `DPI` with a tight bounding box; pyplot figures are closed."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight", pad_inches=0.08)
    try:  # free the memory of pyplot-managed figures; plain Figure objects need nothing
        import matplotlib.pyplot as plt

        plt.close(fig)
    except Exception:  # pragma: no cover - a figure pyplot does not know is fine
        pass
    return buf.getvalue()


def save_figure(fig, path: str | os.PathLike) -> Path:
    """Write ``fig`` as a PNG at ``path`` (one dpi, one bounding box), atomically.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : path
        Destination (written as PNG whatever its suffix).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    from .._paths import atomic_write

    path = Path(path)
    data = figure_png(fig)
    atomic_write(path, lambda fh: fh.write(data), binary=True)
    return path


def describe_figure(fig) -> dict[str, Any]:
    """Title and axis labels of ``fig`` (for the report's checks): ``{"title", "axes": [...]}``.

    Colour bars are left out; an axes that shares its x (y) axis with labelled siblings (small
    multiples) reports their label.
    """
    title = fig._suptitle.get_text() if getattr(fig, "_suptitle", None) is not None else ""
    data_axes = [
        ax
        for ax in fig.axes
        if ax.get_visible()
        and not hasattr(ax, "_colorbar")
        and (ax.lines or ax.collections or ax.images or ax.patches)
    ]

    def label(ax, which: str) -> str:
        own = ax.get_xlabel() if which == "x" else ax.get_ylabel()
        if own:
            return own
        group = ax.get_shared_x_axes() if which == "x" else ax.get_shared_y_axes()
        for other in group.get_siblings(ax):
            text = other.get_xlabel() if which == "x" else other.get_ylabel()
            if text:
                return text
        return ""

    axes = [
        {
            "title": ax.get_title() or ax.get_title("left"),
            "xlabel": label(ax, "x"),
            "ylabel": label(ax, "y"),
        }
        for ax in data_axes
    ]
    return {"title": title, "axes": axes}


def labels_missing(description: dict[str, Any]) -> list[str]:
    """What a figure lacks: a title (figure or every axes) and x/y labels with units."""
    missing = []
    axes: Sequence[dict] = description["axes"]
    if not description["title"] and not all(a["title"] for a in axes):
        missing.append("title")
    for i, a in enumerate(axes):
        for key in ("xlabel", "ylabel"):
            if not a[key]:
                missing.append(f"axes {i} {key}")
            elif "[" not in a[key]:
                missing.append(f"axes {i} {key} has no unit: {a[key]!r}")
    return missing


#: Legend text of the shaded spans where samples were dropped (`shade_dropped`).
DROPPED_LABEL = "dropped near rest"


def shade_dropped(ax, t, dropped, *, label: str = DROPPED_LABEL) -> int:
    """Shade the spans of ``t`` where ``dropped`` is True (one legend entry); the span count.

    A dropped sample is drawn as a gap (NaN), never as a value: shading says why it is empty.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    t : array_like, shape (n,) [s]
    dropped : array_like of bool, shape (n,)
    label : str
        Legend text of the first span.

    Returns
    -------
    int
        Number of shaded spans.
    """
    t = np.asarray(t, dtype=float)
    d = np.asarray(dropped, dtype=bool)
    if t.size == 0 or not d.any():
        return 0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], d.astype(np.int8), [0]])))
    half = 0.5 * float(np.median(np.diff(t))) if t.size > 1 else 0.0
    for k, (i, j) in enumerate(zip(edges[::2], edges[1::2], strict=True)):
        ax.axvspan(
            t[i] - half, t[j - 1] + half, color="0.85", lw=0, zorder=0,
            label=label if k == 0 else None,
        )  # fmt: skip
    return len(edges) // 2
