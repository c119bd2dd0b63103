"""Excitation signals: delayed steps, low-pass filtered steps, sinusoids and multisines.

All generators take a time vector ``t`` [s] and return arrays with time on axis 0. `Sinusoid` and
`Multisine` are also *objects* that `physid.simulate.simulate_linear_ode` recognises, so that a
linear model driven by them is simulated exactly (matrix exponential of the model augmented with
the sine generator) instead of through a sample-and-hold approximation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_1d, check_finite, check_positive, check_time, sample_period
from ..errors import InputError, SamplingError, ShapeError

__all__ = [
    "Sinusoid",
    "Multisine",
    "sinusoid",
    "multisine",
    "schroeder_phases",
    "delayed_steps",
    "filtered_steps",
    "FilteredSteps",
]


# --------------------------------------------------------------------------- sinusoids
@dataclass(frozen=True)
class Sinusoid:
    """``u(t) = amplitude · sin(angular_frequency · t + phase)``.

    Parameters
    ----------
    amplitude : float
        In the unit of the input (for the built-in MSD: the right-hand side u = F/m [m/s²]).
    angular_frequency : float [rad/s]
    phase : float [rad]
    """

    amplitude: float
    angular_frequency: float
    phase: float = 0.0

    def __post_init__(self) -> None:
        for name in ("amplitude", "angular_frequency", "phase"):
            value = getattr(self, name)
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise InputError(f"Sinusoid {name} must be a number; got {value!r}.") from None
            if not np.isfinite(v):
                raise InputError(f"Sinusoid {name} must be finite; got {value!r}.")
            object.__setattr__(self, name, v)
        if self.angular_frequency < 0:
            raise InputError(
                f"Sinusoid angular_frequency must be >= 0 rad/s; got {self.angular_frequency}. "
                "Use a phase of π to flip the sign instead."
            )

    @property
    def components(self) -> tuple[tuple[float, float, float], ...]:
        """``((amplitude, angular_frequency, phase),)``: what an exact simulator needs."""
        return ((self.amplitude, self.angular_frequency, self.phase),)

    def __call__(self, t) -> np.ndarray:
        """Sample the sinusoid at times ``t`` [s]; returns shape (n_samples,)."""
        return sinusoid(t, self.amplitude, self.angular_frequency, self.phase)


def sinusoid(t, amplitude: float, angular_frequency: float, phase: float = 0.0) -> np.ndarray:
    """``amplitude · sin(angular_frequency · t + phase)`` sampled at ``t`` [s], shape (n_samples,).

    Examples
    --------
    >>> sinusoid([0.0, 0.25], 2.0, 2 * np.pi).round(12).tolist()  # a quarter period -> the peak
    [0.0, 2.0]
    """
    t = as_1d(t, "t")
    check_finite(t[:, None], "t")
    return float(amplitude) * np.sin(float(angular_frequency) * t + float(phase))


def schroeder_phases(n_components: int) -> np.ndarray:
    """Schroeder's low-crest-factor phases ``φ_k = −π k (k − 1) / K`` for k = 1..K [rad].

    M. R. Schroeder, "Synthesis of low-peak-factor signals and binary sequences with low
    autocorrelation", IEEE Trans. Inf. Theory 16 (1970) 85-89, for equal amplitudes.
    """
    if not isinstance(n_components, (int, np.integer)) or n_components < 1:
        raise InputError(f"n_components must be a positive integer; got {n_components!r}.")
    k = np.arange(1, int(n_components) + 1)
    return -np.pi * k * (k - 1) / n_components


@dataclass(frozen=True)
class Multisine:
    """``u(t) = Σ_k A_k sin(ω_k t + φ_k)``, by default with Schroeder phases.

    Parameters
    ----------
    angular_frequencies : array_like, shape (K,) [rad/s]
    amplitudes : float or array_like of shape (K,), in the input's unit (default 1)
    phases : "schroeder" or array_like of shape (K,) [rad]
    """

    angular_frequencies: tuple[float, ...]
    amplitudes: tuple[float, ...] | float = 1.0
    phases: tuple[float, ...] | str = "schroeder"

    def __post_init__(self) -> None:
        omega = as_1d(self.angular_frequencies, "angular_frequencies")
        check_finite(omega[:, None], "angular_frequencies")
        if omega.size == 0 or np.any(omega < 0):
            raise InputError(
                "angular_frequencies must be a non-empty list of values >= 0 rad/s; got "
                f"{omega.tolist()}."
            )
        amps = as_1d(self.amplitudes, "amplitudes")
        if amps.size == 1:
            amps = np.full(omega.size, amps[0])
        elif amps.size != omega.size:
            raise ShapeError(
                f"amplitudes must be one value or one per frequency ({omega.size}); got "
                f"{amps.size}."
            )
        check_finite(amps[:, None], "amplitudes")
        if isinstance(self.phases, str):
            if self.phases != "schroeder":
                raise InputError(
                    f"phases must be 'schroeder' or an array of radians; got {self.phases!r}."
                )
            phases = schroeder_phases(omega.size)
        else:
            phases = as_1d(self.phases, "phases")
            if phases.size != omega.size:
                raise ShapeError(
                    f"phases must have one value per frequency ({omega.size}); got {phases.size}."
                )
            check_finite(phases[:, None], "phases")
        object.__setattr__(self, "angular_frequencies", tuple(float(w) for w in omega))
        object.__setattr__(self, "amplitudes", tuple(float(a) for a in amps))
        object.__setattr__(self, "phases", tuple(float(p) for p in phases))

    @property
    def components(self) -> tuple[tuple[float, float, float], ...]:
        """``((A_k, ω_k, φ_k), ...)``."""
        return tuple(zip(self.amplitudes, self.angular_frequencies, self.phases, strict=True))

    def __call__(self, t) -> np.ndarray:
        """Sample at times ``t`` [s]; returns shape (n_samples,)."""
        t = as_1d(t, "t")
        check_finite(t[:, None], "t")
        a = np.asarray(self.amplitudes)
        w = np.asarray(self.angular_frequencies)
        p = np.asarray(self.phases)
        return np.sin(t[:, None] * w + p) @ a


def multisine(t, angular_frequencies, amplitudes=1.0, phases="schroeder") -> np.ndarray:
    """Sum of sinusoids ``Σ_k A_k sin(ω_k t + φ_k)`` sampled at ``t`` [s], shape (n_samples,).

    With the default Schroeder phases the crest factor stays low (about 1.7 for many
    equal-amplitude components, against √(2K) with equal phases), so the excitation power is high
    for a bounded input.
    """
    return Multisine(angular_frequencies, amplitudes, phases)(t)


# --------------------------------------------------------------------------- steps
def delayed_steps(t, step_times, amplitude=1.0) -> np.ndarray:
    """Unit steps delayed to ``step_times``, one channel per step.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
    step_times : array_like, shape (n_steps,) [s]
        Time of each step; channel j is ``amplitude_j · H(t − step_times[j])``.
    amplitude : float or array_like of shape (n_steps,)
        Step heights (the paper's 0.5 rad).

    Returns
    -------
    ndarray, shape (n_samples, n_steps)

    Notes
    -----
    ``H(0) = 1`` (Mathematica's ``UnitStep``), so a sample exactly at the step time is already up.

    Examples
    --------
    >>> delayed_steps([0.0, 1.0, 2.0], [1.0, 3.0], 0.5).tolist()
    [[0.0, 0.0], [0.5, 0.0], [0.5, 0.0]]
    """
    t = as_1d(t, "t")
    check_finite(t[:, None], "t")
    times = as_1d(step_times, "step_times")
    check_finite(times[:, None], "step_times")
    amp = as_1d(amplitude, "amplitude")
    if amp.size not in (1, times.size):
        raise ShapeError(
            f"amplitude must be one value or one per step ({times.size}); got {amp.size}."
        )
    check_finite(amp[:, None], "amplitude")
    return (t[:, None] >= times[None, :]) * np.broadcast_to(amp, times.shape)


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
    from ..filters import design_filter  # filters come after signals in the pipeline

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
