"""Recordings returned by the simulators: plain `Recording` objects whose ``plot()`` draws the
figure of the experiment (joint responses, MSD response) instead of the generic channel plot."""

from __future__ import annotations

from ..signals.recording import Recording

__all__ = ["ClosedLoopRecording", "LinearODERecording"]


class ClosedLoopRecording(Recording):
    """A closed-loop manipulator run: t, q1..qn, qd1..qdn, tau1..taun, r1..rn.

    Parameters
    ----------
    t, data, names, units, metadata
        As for `physid.signals.Recording`, whose constructor it inherits.
    """

    def plot(self, names=None, ax=None, *, torques: bool = False):
        """Joint responses (Cedro & Janecki, Fig. 2); with ``names``/``ax``, the generic plot."""
        if names is not None or ax is not None:
            return super().plot(names=names, ax=ax)
        from ..report.simulation import plot_joint_responses

        return plot_joint_responses(self, torques=torques)


class LinearODERecording(Recording):
    """An open-loop linear ODE run: t, u, x and x_true when noise or a disturbance was added.

    Parameters
    ----------
    t, data, names, units, metadata
        As for `physid.signals.Recording`, whose constructor it inherits.
    """

    def plot(self, names=None, ax=None):
        """Input and response (Oueslati et al., Fig. 4); with ``names``/``ax``, the generic plot."""
        if names is not None or ax is not None:
            return super().plot(names=names, ax=ax)
        from ..report.simulation import plot_msd_response

        return plot_msd_response(self)
