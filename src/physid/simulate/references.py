"""Reference trajectories built from excitation signals and the differential filters.

`filtered_steps` is the reference of Cedro & Janecki (section 4): delayed steps passed through the
Harris-windowed low-pass differential filter, stamped in time as the paper does (``"paper"``,
leading the raw steps by MΔ) or centred on the filter window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_1d, check_positive, check_time, sample_period
from ..errors import InputError, SamplingError
from ..filters import design_filter
from ..signals.excitation import delayed_steps

__all__ = ["FilteredSteps", "filtered_steps"]


@dataclass(frozen=True)
class FilteredSteps:
    """Low-pass filtered delayed steps (the reference of Cedro & Janecki, section 4).

    Attributes
    ----------
    t : ndarray, shape (n_out,) [s]
        Time stamps of the filtered samples (see ``alignment``).
    values : ndarray, shape (n_out, n_steps)
        The filtered steps.
    alignment : str
        ``"paper"``: sample j is stamped ``t[0] + j Δ`` (the paper's ``tp1 = Δ Range[0, ...]``), so
        the filtered reference *leads* the raw steps by ``lead = M Δ``. ``"centred"``: sample j is
        stamped at the time of the input sample at the centre of the filter window, ``t[j + M]``
        (zero phase, ``lead = 0``).
    lead : float [s]
        How far the reference runs ahead of the raw steps.
    half_width, cutoff : int, float
        The filter's M and Ω_g [rad/sample].
    """

    t: np.ndarray
    values: np.ndarray
    alignment: str
    lead: float
    half_width: int
    cutoff: float

    def sample(self, t) -> np.ndarray:
        """Values at times ``t`` [s] by linear interpolation, held constant outside the record.

        The hold is exact outside the record when no step lies within M samples of its ends
        (the filtered step is then flat there), which holds for the paper's reference.
        """
        t = as_1d(t, "t")
        return np.column_stack(
            [np.interp(t, self.t, self.values[:, j]) for j in range(self.values.shape[1])]
        )


def filtered_steps(
    t,
    step_times,
    amplitude=1.0,
    *,
    half_width: int = 100,
    cutoff: float = 0.025,
    alignment: str = "paper",
) -> FilteredSteps:
    """Delayed steps passed through the Harris-windowed low-pass differential filter.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
        Uniform time grid on which the raw steps are sampled (the paper: 0 .. 10 s, Δ = 1 ms).
    step_times : array_like, shape (n_steps,) [s]
        The paper: 1, 3, 5, 7 s.
    amplitude : float or array_like of shape (n_steps,)
        The paper: 0.5 rad.
    half_width : int
        Filter half-width M [samples] (the paper: 100).
    cutoff : float [rad/sample]
        Normalised cut-off Ω_g (the paper: 0.025).
    alignment : {"paper", "centred"}
        How the ``n_samples − 2M`` filter outputs are stamped in time; see `FilteredSteps`.
        ``"paper"`` reproduces Cedro & Janecki's ``tp1 = Δ Range[0, Length[Mf] − 1]``, which
        re-labels the first output (centred on t = MΔ) as t = 0, so the reference leads the raw
        step by MΔ = 0.1 s.

    Returns
    -------
    FilteredSteps
    """
    t = check_time(t, "t")
    dt = sample_period(t, "t")
    if alignment not in ("paper", "centred"):
        raise InputError(f"alignment must be 'paper' or 'centred'; got {alignment!r}.")
    check_positive(cutoff, "cutoff")
    raw = delayed_steps(t, step_times, amplitude)
    filt = design_filter("lowpass", half_width=half_width, cutoff=cutoff, dt=dt)
    m = int(filt.delay)
    if t.size <= 2 * m:
        raise SamplingError(
            f"the low-pass filter needs more than 2M = {2 * m} samples; t has {t.size}. "
            "Lengthen the time grid or reduce half_width."
        )
    # direct summation: exactly 0 where the window sees no step (FFT convolution leaves ~1e-17)
    values = np.asarray(filt.apply(raw, method="direct"), dtype=float)
    n_out = values.shape[0]
    if alignment == "paper":
        t_out = t[0] + dt * np.arange(n_out)
        lead = m * dt
    else:
        t_out = t[m : m + n_out].copy()
        lead = 0.0
    return FilteredSteps(t_out, values, alignment, float(lead), m, float(cutoff))
