"""Tracking plots of the physical parameters a model declares (m, c, k), not its coefficients.

A model written in physical terms (``a = ["k/m", "c/m"]``, ``b = ["1/m"]``; `msd-force`) is
estimated through its coefficients θ; the user asked for m, c and k. `physical_history` maps the
coefficient history of an RLS or algebraic result back to the physical parameters
(`LinearODEModel.physical_from_coefficients`) at up to `HISTORY_POINTS` instants, and
`plot_physical` draws each against time with its final value and 95 % interval.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.figure import Figure

from ..errors import PhysidError
from .style import (
    BAND_COLOR,
    COLORS,
    FINAL_STYLE,
    FULL_WIDTH,
    TRUTH_STYLE,
    legend_outside,
    panel_height,
    robust_limits,
    styled,
)

__all__ = ["HISTORY_POINTS", "physical_history", "plot_physical"]

#: Instants at which the physical parameters are solved from the coefficients for a plot (each
#: is a small nonlinear solve; a figure does not need every sample).
HISTORY_POINTS = 300

#: Two-sided 95 % quantile of the standard normal.
_Z95 = 1.959963984540054


def physical_history(result, n_points: int = HISTORY_POINTS):
    """The identifiable physical parameters of a linear-ODE result along its record.

    Parameters
    ----------
    result : RecursiveResult or AlgebraicResult
        With ``t``, ``names``, ``series(name)``, ``physical`` and ``model``.
    n_points : int
        At most this many instants, evenly spaced over the samples with a defined estimate.

    Returns
    -------
    tuple (t, dict) or None
        ``t`` [s], shape (k,), and name → values, shape (k,) (NaN where the solve failed); None
        when the model declares no physical parameters the coefficients determine.
    """
    physical = getattr(result, "physical", None) or {}
    model = getattr(result, "model", None)
    names = list(physical.get("identifiable") or [])
    if not names or model is None or not hasattr(model, "physical_from_coefficients"):
        return None
    est = np.column_stack([np.asarray(result.series(n), dtype=float) for n in result.names])
    ok = np.flatnonzero(np.all(np.isfinite(est), axis=1))
    if ok.size == 0:
        return None
    pick = ok[np.unique(np.linspace(0, ok.size - 1, min(n_points, ok.size)).astype(int))]
    out = {n: np.full(pick.size, np.nan) for n in names}
    for k, i in enumerate(pick):  # one small solve per plotted instant, not per sample
        try:
            values = model.physical_from_coefficients(dict(zip(result.names, est[i], strict=True)))
        except (PhysidError, ValueError, ArithmeticError):
            continue
        for n in names:
            out[n][k] = float(values.values.get(n, np.nan))
    return np.asarray(result.t, dtype=float)[pick], out


@styled
def plot_physical(result, truth: Mapping[str, float] | None = None, *, title: str = "") -> Figure:
    """Each declared physical parameter against time, with its final value and 95 % interval.

    Parameters
    ----------
    result : RecursiveResult or AlgebraicResult
        A fit of a model in physical terms (see `physical_history`).
    truth : mapping, optional
        True values (``m``, ``c``, ``k``) drawn dashed.
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    InputError
        The model declares no physical parameters the estimate determines.
    """
    from ..errors import InputError

    history = physical_history(result)
    if history is None:
        raise InputError(
            "the model declares no physical parameters that this estimate determines; plot the "
            "coefficients with result.plot() instead."
        )
    t, series = history
    physical = result.physical or {}
    final = dict(physical.get("values") or {})
    stderr = dict(physical.get("stderr") or {})
    units = dict(getattr(getattr(result, "model", None), "units", {}) or {})
    truth = dict(truth or {})
    fig = Figure(figsize=(FULL_WIDTH, panel_height(len(series), 2.0)), layout="constrained")
    axes = fig.subplots(len(series), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (name, values) in zip(axes, series.items(), strict=True):
        ax.plot(t, values, color=COLORS[0], lw=1.2, label="estimate over time")
        value, se = final.get(name), stderr.get(name)
        if value is not None and np.isfinite(value):
            text = f"final {value:.5g}" + (f" ± {_Z95 * se:.2g} (95 %)" if se else "")
            ax.axhline(value, **FINAL_STYLE, label=text)
            if se:
                ax.axhspan(value - _Z95 * se, value + _Z95 * se, color=BAND_COLOR, alpha=0.2,
                           lw=0, label="95 % interval")  # fmt: skip
        true = truth.get(name)
        if true is not None:
            ax.axhline(true, **TRUTH_STYLE, label=f"true value {true:.5g}")
        limits = robust_limits(values, truth=true, final=value)
        if limits is not None:
            ax.set_ylim(*limits)
        ax.set_ylabel(f"{name} [{units[name]}]" if units.get(name) else name)
        legend_outside(ax)
    axes[-1].set_xlabel("time [s]")
    head = title or f"{result.method}: the model's physical parameters"
    if not stderr:  # say why there is no interval instead of drawing none silently
        import textwrap

        why = str(getattr(result, "stderr_reason", None) or "no standard errors")
        head += "\n" + textwrap.shorten("no 95 % interval: " + why, 150, placeholder=" …")
    axes[0].set_title(head, fontsize="small" if not stderr else None)
    return fig
