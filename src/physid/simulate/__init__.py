"""Simulation: exact sampled runs of linear ODE models and closed-loop PD runs of chain models.

* `simulate_linear_ode` / `simulate_msd` / `msd_paper_scenario`: linear models driven by exact
  sinusoids (matrix exponential of the model augmented with the sine generator) or held samples,
  with parameter jumps, white noise at a given SNR and sinusoidal disturbances (Oueslati et al.,
  2011).
* `simulate_closed_loop` / `paper_manipulator_experiment`: PD control of a manipulator integrated
  with scipy's DOP853 (Cedro & Janecki, section 4); `pd_rhs` is the PD law fused with a model.
"""

from .closed_loop import (
    PAPER_MANIPULATOR,
    ReferenceTrajectory,
    closed_loop_rhs,
    make_reference,
    paper_manipulator_experiment,
    paper_reference,
    simulate_closed_loop,
)
from .linear import linear_ode_state_space, simulate_linear_ode, uniform_time
from .msd import PAPER_MSD, MSDParameters, msd_paper_scenario, msd_parameters, simulate_msd
from .pd import pd_rhs
from .recordings import ClosedLoopRecording, LinearODERecording
from .references import FilteredSteps, filtered_steps

__all__ = [
    "simulate_linear_ode",
    "linear_ode_state_space",
    "uniform_time",
    "simulate_msd",
    "msd_paper_scenario",
    "msd_parameters",
    "MSDParameters",
    "PAPER_MSD",
    "simulate_closed_loop",
    "paper_manipulator_experiment",
    "paper_reference",
    "closed_loop_rhs",
    "pd_rhs",
    "make_reference",
    "ReferenceTrajectory",
    "FilteredSteps",
    "filtered_steps",
    "PAPER_MANIPULATOR",
    "ClosedLoopRecording",
    "LinearODERecording",
]
