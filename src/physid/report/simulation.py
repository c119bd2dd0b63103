"""Figures of simulated experiments: manipulator joint responses (Cedro & Janecki, Fig. 2) and
mass-spring-damper responses (Oueslati et al., Fig. 4).

Functions return a `matplotlib.figure.Figure` built without pyplot (no global state, no
``plt.show``).
"""

from __future__ import annotations

from matplotlib.figure import Figure

from ..errors import InputError
from .style import COLORS, FULL_WIDTH, legend_outside, panel_height, styled

__all__ = ["plot_joint_responses", "plot_msd_response"]

_JOINT_COLOURS = COLORS
_JOINT_DASHES = ("-", "-", "-", "-", "-", "-", "-", "-")


@styled
def plot_joint_responses(
    recording, *, references: bool = True, torques: bool = False, title: str | None = None
) -> Figure:
    """Joint angles against time, like the paper's Fig. 2 (φ1..φ4 in red, green, blue, yellow).

    Parameters
    ----------
    recording : Recording
        With channels ``q1..qn`` [rad] and optionally ``r1..rn`` [rad] and ``tau1..taun`` [N·m]
        (as written by `physid.simulate.paper_manipulator_experiment`).
    references : bool
        Draw the references r_k dashed in the same colours.
    torques : bool
        Add a lower panel with the applied torques τ_k.
    title : str, optional
        The figure's title (default: a generic one).

    Returns
    -------
    matplotlib.figure.Figure
    """
    q_names = recording.channels("q")
    if not q_names:
        raise InputError(
            "plot_joint_responses needs channels q1..qn; the recording has "
            f"{list(recording.names)}."
        )
    r_names = recording.channels("r") if references else []
    tau_names = recording.channels("tau") if torques else []
    if torques and not tau_names:
        raise InputError("torques=True needs channels tau1..taun in the recording.")
    n_panels = 2 if tau_names else 1
    fig = Figure(figsize=(FULL_WIDTH, panel_height(n_panels, 3.2)), layout="constrained")
    axes = fig.subplots(n_panels, 1, sharex=True, squeeze=False)[:, 0]
    ax = axes[0]
    for k, name in enumerate(q_names):
        colour = _JOINT_COLOURS[k % len(_JOINT_COLOURS)]
        ax.plot(
            recording.t,
            recording[name],
            color=colour,
            linestyle="-",
            linewidth=1.4,
            label=f"φ{k + 1} ({name})",
        )
        if k < len(r_names):
            ax.plot(
                recording.t,
                recording[r_names[k]],
                color=colour,
                linewidth=0.9,
                linestyle=(0, (4, 2)),
                label=f"r{k + 1} (reference)",
            )
    ax.set_ylabel("φ [rad]")
    ax.set_xlabel("t [s]")
    ax.set_title(title or "Joint responses of the closed loop (cf. Cedro & Janecki, Fig. 2)")
    legend_outside(ax)
    if tau_names:
        tax = axes[1]
        for k, name in enumerate(tau_names):
            tax.plot(
                recording.t,
                recording[name],
                color=_JOINT_COLOURS[k % len(_JOINT_COLOURS)],
                linewidth=1.0,
                label=name,
            )
        tax.set_ylabel("τ [N·m]")
        tax.set_xlabel("t [s]")
        legend_outside(tax)
    axes[-1].set_xlabel("t [s]")
    return fig


def plot_msd_response(recording) -> Figure:
    """Input u and (noisy and clean) position x of a mass-spring-damper simulation.

    Parameters
    ----------
    recording : Recording
        Channels ``u`` [m/s²], ``x`` [m] and optionally ``x_true`` [m]
        (as written by `physid.simulate.msd_paper_scenario`).

    Returns
    -------
    matplotlib.figure.Figure
        Two panels: x (measured, and clean when present) above, u below.
    """
    missing = [n for n in ("u", "x") if n not in recording.names]
    if missing:
        raise InputError(
            f"plot_msd_response needs channels u and x; the recording lacks {missing} "
            f"(it has {list(recording.names)})."
        )
    fig = Figure(figsize=(8, 5), layout="constrained")
    ax_x, ax_u = fig.subplots(2, 1, sharex=True)
    ax_x.plot(recording.t, recording["x"], color="tab:blue", linewidth=0.8, label="x (measured)")
    if "x_true" in recording.names:
        ax_x.plot(recording.t, recording["x_true"], color="black", linewidth=1.0, label="x (clean)")
    noise = recording.metadata.get("noise") or {}
    snr = noise.get("snr_db_requested")
    title = "Mass-spring-damper response"
    if snr is not None:
        title += f", SNR = {snr:g} dB"
    ratio = recording.metadata.get("ratio")
    if ratio is not None:
        title += f", Z = ω1/ω0 = {ratio:g}"
    ax_x.set_title(title)
    ax_x.set_ylabel(f"x [{recording.unit('x') or '-'}]")
    ax_x.grid(True, alpha=0.3)
    ax_x.legend(loc="best", fontsize="small")
    ax_u.plot(recording.t, recording["u"], color="tab:red", linewidth=0.8)
    ax_u.set_ylabel(f"u [{recording.unit('u') or '-'}]")
    ax_u.set_xlabel("t [s]")
    ax_u.grid(True, alpha=0.3)
    return fig
