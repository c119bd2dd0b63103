"""Analysis: identifiability, variance-based input design, convergence metrics, Monte-Carlo sweeps.

`montecarlo` runs locally by default; its Dask backend needs the ``dask`` extra
(``pip install "physid[dask]"``), imported only when asked for.
"""

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
from .montecarlo import SweepResult, msd_sweep, run_sweep, trial_specs

__all__ = [
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
]
