"""Excitation signals: delayed steps, sinusoids and multisines.

Low-pass filtered steps (the reference of Cedro & Janecki) need the differential filters, a later
stage, so they live in `physid.simulate.references`.

All generators take a time vector ``t`` [s] and return arrays with time on axis 0. `Sinusoid` and
`Multisine` are also *objects* that `physid.simulate.simulate_linear_ode` recognises, so that a
linear model driven by them is simulated exactly (matrix exponential of the model augmented with
the sine generator) instead of through a sample-and-hold approximation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_1d, check_finite, check_int
from ..errors import InputError, ShapeError

__all__ = [
    "Sinusoid",
    "Multisine",
    "sinusoid",
    "multisine",
    "schroeder_phases",
    "delayed_steps",
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

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
        Sample times.
    amplitude : float
        In the unit of the signal.
    angular_frequency : float [rad/s]
        ω.
    phase : float [rad]
        φ.

    Returns
    -------
    ndarray, shape (n_samples,)
        The samples.

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

    Parameters
    ----------
    n_components : int
        K >= 1.

    Returns
    -------
    ndarray, shape (K,) [rad]
        The phases φ_1 … φ_K.
    """
    n_components = check_int(n_components, "n_components", minimum=1)
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

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
        Sample times.
    angular_frequencies : array_like, shape (K,) [rad/s]
        ω_k.
    amplitudes : float or array_like, shape (K,)
        A_k (a scalar: the same for all).
    phases : "schroeder" or array_like, shape (K,) [rad]
        φ_k; ``"schroeder"`` uses `schroeder_phases`.

    Returns
    -------
    ndarray, shape (n_samples,)
        The samples.
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
