"""Reference trajectories built from excitation signals and the differential filters.

`filtered_steps` is the reference of Cedro & Janecki (section 4): delayed steps passed through the
Harris-windowed low-pass differential filter, stamped in time as the paper does (``"paper"``,
leading the raw steps by MΔ) or centred on the filter window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_1d, as_2d, check_finite, check_positive, check_time, sample_period
from ..errors import InputError, SamplingError, ShapeError
from ..filters import design_filter
from ..signals.excitation import delayed_steps

__all__ = ["FilteredSteps", "filtered_steps", "ReferenceTrajectory", "make_reference"]


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


# --------------------------------------------------------------------------- reference
@dataclass(frozen=True, eq=False)
class ReferenceTrajectory:
    """A joint reference r(t) [rad]: a C² cubic spline through samples, held constant outside.

    Calling it with a float returns a list of n_joints floats (cheap, for the integrator's
    right-hand side); `sample` evaluates whole arrays.

    Attributes
    ----------
    t : ndarray (n_knots,) [s]
    values : ndarray (n_knots, n_joints) [rad]
    """

    t: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        v = np.asarray(self.values, dtype=float)
        if t.size >= 2:
            from scipy.interpolate import CubicSpline

            spline = CubicSpline(t, v, axis=0)
            # per interval i and joint j the polynomial coefficients (c3, c2, c1, c0) in s = t − t_i
            coef = np.transpose(spline.c, (1, 2, 0))  # (n_intervals, n_joints, 4)
            coef = np.ascontiguousarray(coef)
            coef.setflags(write=False)
            object.__setattr__(self, "_coef_array", coef)
            object.__setattr__(self, "_coef", coef.tolist())
            uniform = np.ptp(np.diff(t)) <= 1e-9 * (t[-1] - t[0])
            object.__setattr__(
                self, "_uniform_h", (t[-1] - t[0]) / (t.size - 1) if uniform else None
            )
            object.__setattr__(self, "_spline", spline)
        else:
            object.__setattr__(self, "_coef_array", np.zeros((0, v.shape[1], 4)))
            object.__setattr__(self, "_uniform_h", None)
        object.__setattr__(self, "_t0", float(t[0]))
        object.__setattr__(self, "_t1", float(t[-1]))
        object.__setattr__(self, "_first", v[0].tolist())
        object.__setattr__(self, "_last", v[-1].tolist())
        object.__setattr__(self, "_knots", t.tolist())

    @property
    def n_joints(self) -> int:
        """Number of joints (columns of ``values``)."""
        return int(np.asarray(self.values).shape[1])

    @property
    def uniform_step(self) -> float | None:
        """Knot spacing [s] when the knots are uniform, else None."""
        return self._uniform_h

    @property
    def coefficients(self) -> np.ndarray:
        """Spline coefficients (n_intervals, n_joints, 4): c3, c2, c1, c0 in s = t − t_i."""
        return self._coef_array

    def __call__(self, t: float) -> list[float]:
        """r(t) as a list of floats [rad] for one time t [s] (Horner on the interval's cubic)."""
        if t <= self._t0:
            return self._first
        if t >= self._t1:
            return self._last
        h = self._uniform_h
        if h is not None:
            i = min(int((t - self._t0) / h), len(self._coef) - 1)
            s = t - (self._t0 + i * h)
        else:
            i = int(np.searchsorted(self.t, t, side="right")) - 1
            s = t - self._knots[i]
        return [((c3 * s + c2) * s + c1) * s + c0 for c3, c2, c1, c0 in self._coef[i]]

    def sample(self, t) -> np.ndarray:
        """r at an array of times [s] -> (n_samples, n_joints), constant outside the knots."""
        t = as_1d(t, "t")
        if np.asarray(self.t).size < 2:
            return np.tile(self.values[0], (t.size, 1))
        clipped = np.clip(t, self._t0, self._t1)
        return self._spline(clipped)


def make_reference(reference, n_joints: int, t_grid: np.ndarray | None = None):
    """Normalise a joint reference to a callable ``r(t) -> sequence of n_joints`` [rad].

    Parameters
    ----------
    reference : ReferenceTrajectory, FilteredSteps, array_like or callable
        One of: a `ReferenceTrajectory` (returned as is); a `FilteredSteps` (its samples,
        interpolated by a cubic spline); a constant array, shape (n_joints,) [rad]; an array of
        samples, shape (n_samples, n_joints) [rad], on `t_grid` (cubic spline); or a callable
        ``r(t)`` (t [s]) returning n_joints angles [rad] (returned as is after a probe at t = 0).
    n_joints : int
        Number of joints the reference must provide.
    t_grid : ndarray, shape (n_samples,) [s], optional
        Time stamps of a sampled-array reference (required only for that form).

    Returns
    -------
    ReferenceTrajectory or callable
        ``r(t)`` [rad] for scalar t [s]; a `ReferenceTrajectory` also evaluates whole arrays.

    Raises
    ------
    ShapeError
        The reference does not hold `n_joints` angles, or a sampled reference does not have one
        row per sample of `t_grid`.
    InputError
        Non-finite reference values.
    """
    if isinstance(reference, ReferenceTrajectory):
        ref = reference
    elif isinstance(reference, FilteredSteps):
        ref = ReferenceTrajectory(reference.t, reference.values)
    elif callable(reference):
        probe = np.asarray(reference(0.0), dtype=float).reshape(-1)
        if probe.size != n_joints:
            raise ShapeError(
                f"reference(t) must return {n_joints} angles [rad]; got {probe.size} values."
            )
        return reference
    else:
        arr = np.asarray(reference, dtype=float)
        if arr.ndim <= 1:
            arr = as_1d(arr, "reference")
            if arr.size != n_joints:
                raise ShapeError(
                    f"a constant reference must hold {n_joints} angles [rad]; got {arr.size}."
                )
            check_finite(arr[None, :], "reference")
            ref = ReferenceTrajectory(np.array([0.0]), arr[None, :])
        else:
            arr = as_2d(arr, "reference", n_channels=n_joints)
            check_finite(arr, "reference")
            if t_grid is None or arr.shape[0] != t_grid.size:
                raise ShapeError(
                    "a sampled reference must have one row per time sample "
                    f"({None if t_grid is None else t_grid.size}); "
                    f"got {arr.shape[0]} rows. Give a callable r(t) or a ReferenceTrajectory "
                    "for other grids."
                )
            ref = ReferenceTrajectory(t_grid, arr)
    if ref.n_joints != n_joints:
        raise ShapeError(f"the reference has {ref.n_joints} joints; the model has {n_joints}.")
    return ref
