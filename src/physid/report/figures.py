"""General figures: a recording's channels against time.

Functions return a `matplotlib.figure.Figure` built without pyplot (no global state, no
``plt.show``), so they work under any backend and in worker processes.
"""

from __future__ import annotations

from collections.abc import Sequence

from matplotlib.figure import Figure

from ..errors import InputError

__all__ = ["plot_recording"]


def plot_recording(rec, names: Sequence[str] | None = None, ax=None) -> Figure:
    """Plot channels of a recording against time.

    Parameters
    ----------
    rec : physid.signals.Recording
    names : sequence of str, optional
        Channels to draw (default: all), one line each.
    ax : matplotlib.axes.Axes, optional
        Draw every channel on this axes. By default a new figure gets one panel per unit, so
        that channels in the same unit share a y axis (e.g. ``q1..q4`` [rad] and ``tau1..tau4``
        [N·m] on two panels).

    Returns
    -------
    matplotlib.figure.Figure
        The figure holding the axes (``ax.figure`` when ``ax`` is given).
    """
    names = list(rec.names if names is None else names)
    if not names:
        raise InputError("plot_recording needs at least one channel; names is empty.")
    missing = [n for n in names if n not in rec.names]
    if missing:
        raise InputError(f"the recording lacks channel(s) {missing}; it has {list(rec.names)}.")
    if ax is not None:
        for name in names:
            ax.plot(rec.t, rec[name], label=_label(name, rec.unit(name)))
        ax.set_xlabel("t [s]")
        ax.legend(loc="best", fontsize="small")
        return ax.figure
    groups: dict[str, list[str]] = {}
    for name in names:
        groups.setdefault(rec.unit(name), []).append(name)
    fig = Figure(figsize=(8, 2.2 + 1.8 * len(groups)), layout="constrained")
    axes = fig.subplots(len(groups), 1, sharex=True, squeeze=False)[:, 0]
    for panel, (unit, members) in zip(axes, groups.items(), strict=True):
        for name in members:
            panel.plot(rec.t, rec[name], label=name, linewidth=1.0)
        panel.set_ylabel(f"[{unit}]" if unit else "value")
        panel.legend(loc="best", fontsize="small", ncol=min(4, len(members)))
        panel.grid(True, alpha=0.3)
    axes[-1].set_xlabel("t [s]")
    source = rec.metadata.get("source") if hasattr(rec, "metadata") else None
    if source:
        fig.suptitle(str(source), fontsize="medium")
    return fig


def _label(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit else name
