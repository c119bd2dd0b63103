"""Differential filters: the Harris-windowed FIR low-pass, d/dt and d²/dt² of Cedro & Janecki.

Design (`design_filter`) is separate from application (`DifferentialFilter.apply` for the
samples, `DifferentialFilter.filter_signal` for a `FilteredSignal` of samples and aligned times);
every filter reports its delay, valid range, frequency response and white-noise gain.
`filter_derivatives` returns the low-passed signal and both derivatives, aligned on the same
output times. `state_variable_filter` (in ``state_variable.py``) is the causal Butterworth
state-variable filter of the recursive estimator, batch and streaming. `filter_band_check` (in ``band.py``) measures whether a motion fits a filter's flat
pass band. `sosfiltfilt_decimated` (in ``lifted.py``) is `scipy.signal.sosfiltfilt` computed only
at every nd-th sample (the IDIM parallel filter).
"""

from .band import (
    ENERGY_FRACTION_WARN,
    PASSBAND_TOL,
    FilterBandCheck,
    FilterChoice,
    choose_filter,
    filter_band_check,
    noise_floor,
    passband_edge,
    white_floor,
)
from .differential import (
    BANK_DESIGNS,
    KINDS,
    DifferentialFilter,
    FilteredDerivatives,
    FilteredSignal,
    design_filter,
    design_filter_bank,
    filter_derivatives,
    harris_window,
    ideal_impulse_response,
)
from .lifted import (
    LIFT_MIN_ND,
    LIFT_MIN_WORK,
    decimated_filtfilt,
    lifting_pays,
    sosfiltfilt_decimated,
)
from .state_variable import (
    SVF_TRANSIENT_TOL,
    StreamingStateVariableFilter,
    state_variable_filter,
    svf_transient_samples,
)

__all__ = [
    "ENERGY_FRACTION_WARN",
    "PASSBAND_TOL",
    "FilterBandCheck",
    "filter_band_check",
    "passband_edge",
    "FilterChoice",
    "choose_filter",
    "noise_floor",
    "white_floor",
    "BANK_DESIGNS",
    "design_filter_bank",
    "KINDS",
    "DifferentialFilter",
    "FilteredDerivatives",
    "FilteredSignal",
    "design_filter",
    "filter_derivatives",
    "harris_window",
    "ideal_impulse_response",
    "LIFT_MIN_ND",
    "LIFT_MIN_WORK",
    "decimated_filtfilt",
    "lifting_pays",
    "sosfiltfilt_decimated",
    "SVF_TRANSIENT_TOL",
    "state_variable_filter",
    "StreamingStateVariableFilter",
    "svf_transient_samples",
]
