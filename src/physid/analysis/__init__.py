"""Analysis: identifiability, variance-based input design, convergence metrics, Monte-Carlo sweeps.

`montecarlo` is the sweep engine's public module (grid × seeds on a serial, process-pool or Dask
backend; Dask needs the ``dask`` extra, ``pip install "physid[dask]"``, imported only when asked
for; the code is in `sweep_trials`, `sweep_backends` and `sweep_run`) and `sweep_table` its result
table and files;
`studies` builds its trials from a model, a scenario and an estimator (`model_sweep`: any
linear-ODE model); `msd_study` is the paper's MSD study on it (`msd_sweep`).
"""

from .excitation import ExcitationDesign, design_excitation
from .identifiability import (
    IdentifiabilityWarning,
    NumericIdentifiability,
    StructuralIdentifiability,
    numeric_identifiability,
    structural_identifiability,
)
from .input_design import InputDesignResult, design_input, optimal_ratio, variance_factor
from .metrics import (
    convergence_times,
    first_hit_time,
    recovery_times,
    relative_error,
    settle_time,
    shortest_window,
)
from .msd_study import msd_sweep
from .studies import EstimationTrial, SineScenario, model_sweep
from .sweep_run import run_sweep
from .sweep_table import SweepResult
from .sweep_trials import trial_specs

__all__ = [
    "ExcitationDesign",
    "design_excitation",
    "IdentifiabilityWarning",
    "StructuralIdentifiability",
    "NumericIdentifiability",
    "structural_identifiability",
    "numeric_identifiability",
    "InputDesignResult",
    "design_input",
    "optimal_ratio",
    "variance_factor",
    "relative_error",
    "first_hit_time",
    "settle_time",
    "convergence_times",
    "recovery_times",
    "shortest_window",
    "SweepResult",
    "run_sweep",
    "msd_sweep",
    "trial_specs",
    "model_sweep",
    "EstimationTrial",
    "SineScenario",
]
