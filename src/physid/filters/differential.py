"""Harris-windowed FIR low-pass, first- and second-derivative filters (the paper's Filtr/1/2).

Reference: Cedro & Janecki, "Identification of a manipulator model using the input error method
in the Mathematica program", section 3 (functions ``Filtr``, ``Filtr1``, ``Filtr2``).

Design
------
The ideal responses over the pass band ``|Ω| <= Ω_g`` (Ω in rad/sample, Δ the sample period [s])
are ``H0 = 1``, ``H1 = jΩ/Δ`` and ``H2 = (jΩ/Δ)²``; outside the band they are 0. Their impulse
responses are the paper's integral (4), ``h_k[n] = (1/2π) ∫_{-Ω_g}^{Ω_g} H_k(Ω) e^{jΩn} dΩ``,
which in closed form (derived with sympy, checked against quadrature in the tests) are::

    h0[n] = sin(Ω_g n) / (π n)                                        h0[0] = Ω_g / π
    h1[n] = (Ω_g n cos(Ω_g n) - sin(Ω_g n)) / (π Δ n²)                h1[0] = 0
    h2[n] = (2 sin x - 2 x cos x - x² sin x) / (π Δ² n³),  x = Ω_g n    h2[0] = -Ω_g³ / (3 π Δ²)

We evaluate them through spherical Bessel functions, which is the same thing without the
cancellation of the raw forms at small ``Ω_g n`` (relative error ~1e-15 everywhere)::

    h0[n] = (Ω_g/π) j0(x),   h1[n] = -(Ω_g²/(πΔ)) j1(x),
    h2[n] = (Ω_g³/(πΔ²)) (2 j2(x) - j0(x)) / 3.

Each is multiplied by the 4-term Harris window ``w[n] = 0.36 + 0.49 cos(nπ/M) + 0.14 cos(2nπ/M)
+ 0.01 cos(3nπ/M)``, n = -M..M, and normalised exactly as the paper's κ factors do:

- low-pass: ``c0 = h0 w / κH1`` with ``κH1 = Σ h0 w``: DC gain exactly 1;
- first derivative: ``c1 = -h1 w / κH2`` with ``κH2 = Σ h1 w (0 - nΔ)``: slope exactly 1 on a ramp,
  exactly 0 on a constant (the taps are odd, made exactly antisymmetric here);
- second derivative: ``g = h2 w - κH3 c0`` with ``κH3 = Σ h2 w`` (its DC part removed with the
  low-pass), then ``c2 = -2 g / κH4`` with ``κH4 = Σ g (0 - (Δn)²)``: exactly 2 on t², 0 on a
  constant and on t (even taps).

Application (correlation, not convolution)
------------------------------------------
The paper applies the taps by *correlation*: ``y[i] = Σ_{n=-M}^{M} c[n] x[i+n]``
(``x[[Range[i-M, i+M]]] . h1p``). The sign ``-1/κH2`` in ``Filtr1`` compensates for that: the
convolution ``Σ c[n] x[i-n]`` with the same taps would return the *negative* derivative. `taps`
holds these correlation taps in the order n = -M..M, exactly like the paper's ``h0p``, ``h1p``,
``h2p``; the output row ``j`` belongs to input sample ``j + M`` (a centred, non-causal filter of
delay M samples when run causally).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field

import numpy as np
from scipy import signal, special

from .._validate import as_1d, check_finite, check_int, check_length, check_time, sample_period
from ..errors import InputError, SamplingError, ShapeError

__all__ = [
    "BANK_DESIGNS",
    "design_filter_bank",
    "DifferentialFilter",
    "FilteredDerivatives",
    "FilteredSignal",
    "design_filter",
    "filter_derivatives",
    "harris_window",
    "ideal_impulse_response",
    "KINDS",
]

#: Filter kinds and their derivative order.
KINDS: dict[str, int] = {"lowpass": 0, "first": 1, "second": 2}
_KIND_BY_ORDER = {v: k for k, v in KINDS.items()}


def harris_window(half_width: int) -> np.ndarray:
    """The paper's 4-term Harris window ``w[n]``, n = -M..M.

    Parameters
    ----------
    half_width : int
        M; the window has ``2M + 1`` points and is 0 at n = ±M.

    Returns
    -------
    ndarray, shape (2M+1,)
        ``0.36 + 0.49 cos(nπ/M) + 0.14 cos(2nπ/M) + 0.01 cos(3nπ/M)``.
    """
    m = _check_half_width(half_width)
    phase = np.pi * np.arange(-m, m + 1) / m
    return 0.36 + 0.49 * np.cos(phase) + 0.14 * np.cos(2 * phase) + 0.01 * np.cos(3 * phase)


def ideal_impulse_response(order: int, half_width: int, cutoff: float, dt: float) -> np.ndarray:
    """Closed-form ``h_k[n] = (1/2π) ∫_{-Ω_g}^{Ω_g} (jΩ/Δ)^k e^{jΩn} dΩ`` for n = -M..M (eq. 4).

    Parameters
    ----------
    order : {0, 1, 2}
        Derivative order k.
    half_width : int
        M.
    cutoff : float [rad/sample]
        Ω_g, 0 < Ω_g <= π.
    dt : float [s]
        Sample period Δ.

    Returns
    -------
    ndarray, shape (2M+1,) [1/s^k]
        The truncated ideal impulse response (convolution form, before windowing).
    """
    m = _check_half_width(half_width)
    n = np.arange(1, m + 1, dtype=float)
    x = cutoff * n
    if order == 0:
        pos = cutoff / np.pi * special.spherical_jn(0, x)  # sin(x) / (π n)
        centre = cutoff / np.pi
        sign = 1.0
    elif order == 1:
        pos = -(cutoff**2) / (np.pi * dt) * special.spherical_jn(1, x)  # (x cos x - sin x)/(π Δ n²)
        centre = 0.0
        sign = -1.0  # odd
    elif order == 2:
        # (2 sin x - 2x cos x - x² sin x) / (π Δ² n³) = Ω_g³/(πΔ²) · (2 j2(x) - j0(x)) / 3
        bessel = 2 * special.spherical_jn(2, x) - special.spherical_jn(0, x)
        pos = cutoff**3 / (np.pi * dt**2) * bessel / 3
        centre = -(cutoff**3) / (3 * np.pi * dt**2)
        sign = 1.0
    else:
        raise InputError(f"order must be 0, 1 or 2; got {order!r}.")
    # mirror the n > 0 half so that the symmetry (even or odd) is exact in floating point
    return np.concatenate([sign * pos[::-1], [centre], pos])


@dataclass(frozen=True, eq=False)
class DifferentialFilter:
    """A designed, centred FIR filter: low-pass, first or second derivative.

    Build one with `design_filter`. The taps are *correlation* taps (like the paper's ``h0p``,
    ``h1p``, ``h2p``): ``y[i] = Σ_{n=-M}^{M} taps[n + M] · x[i + n]``.

    Attributes
    ----------
    kind : {"lowpass", "first", "second"}
    order : int
        Derivative order (0, 1, 2).
    half_width : int
        M; the filter has ``2M + 1`` taps and is valid from input sample M to n - M - 1.
    cutoff : float [rad/sample]
        Ω_g.
    dt : float [s]
        Sample period Δ the taps were scaled for.
    taps : ndarray, shape (2M+1,) [1/s^order]
        Read-only correlation taps, n = -M..M.
    """

    kind: str
    order: int
    half_width: int
    cutoff: float
    dt: float
    taps: np.ndarray = field(repr=False)

    # ------------------------------------------------------------------ derived quantities
    @property
    def n_taps(self) -> int:
        """Number of taps, ``2M + 1``."""
        return 2 * self.half_width + 1

    @property
    def delay(self) -> int:
        """Delay [samples] if run causally: output row j belongs to input sample j + M."""
        return self.half_width

    @property
    def delay_seconds(self) -> float:
        """Delay [s], ``M Δ``."""
        return self.half_width * self.dt

    @property
    def white_noise_gain(self) -> float:
        """Output standard deviation per unit input standard deviation of white noise [1/s^order].

        ``sqrt(Σ taps²)``: for white input noise of standard deviation σ, the filtered noise has
        standard deviation ``σ · white_noise_gain`` (in the input's unit per s^order).
        """
        return float(np.sqrt(np.sum(self.taps**2)))

    # ------------------------------------------------------------------ application
    def valid_slice(self, n_samples: int, *, paper: bool = False) -> slice:
        """Input samples that get an output: ``slice(M, n - M)`` (``n - M - 1`` when ``paper``).

        Parameters
        ----------
        n_samples : int
            Length n of the record to be filtered [samples].
        paper : bool
            Drop one more sample at the end, like the paper's loop ``i = M+1 .. NN-M-1``.

        Returns
        -------
        slice
            Indices into the input [samples]; ``x[valid_slice(n)]`` are the input samples the
            output rows belong to, in order.

        Raises
        ------
        SamplingError
            The record is shorter than the filter (``2M + 1`` samples, ``2M + 2`` when
            ``paper``).

        Examples
        --------
        >>> f = design_filter("lowpass", half_width=3, cutoff=0.5, dt=1.0)
        >>> f.valid_slice(10), f.valid_slice(10, paper=True)
        (slice(3, 7, None), slice(3, 6, None))
        """
        n_samples = int(n_samples)
        self._check_length(n_samples, paper)
        stop = n_samples - self.half_width - (1 if paper else 0)
        return slice(self.half_width, stop)

    def output_time(self, t, *, paper: bool = False) -> np.ndarray:
        """Times [s] of the output rows: ``t[M : n - M]`` (one fewer at the end when ``paper``).

        Note: the paper restarts the filtered signal's time at 0 (``tp1 = Δ Range[0, ...]``); we
        keep the true time of each output, which is ``M Δ`` later.

        Parameters
        ----------
        t : array_like, shape (n_samples,) [s]
            Sample times of the input.
        paper : bool
            Drop one more sample at the end, like the paper.

        Returns
        -------
        ndarray, shape (n_samples - 2M,) [s]
            (``n_samples - 2M - 1`` when ``paper``.)
        """
        t = as_1d(t, "t")
        return t[self.valid_slice(t.size, paper=paper)]

    def apply(self, x, *, paper: bool = False, method: str = "fft") -> np.ndarray:
        """Filter ``x`` along axis 0 (time).

        Parameters
        ----------
        x : array_like, shape (n_samples, n_channels) or (n_samples,)
            Uniformly sampled signal (sample period `dt`).
        paper : bool
            Drop one more sample at the end, like the paper's loop ``i = M+1 .. NN-M-1``.
        method : {"fft", "direct"}
            ``"fft"``: overlap-add FFT convolution (``scipy.signal.oaconvolve``), fast for long
            records. ``"direct"``: the paper's dot product ``x[i-M..i+M] · taps`` with the
            same floating-point operations in the same order as the literal loop
            ``acc = 0; for k: acc += x[i-M+k] · taps[k]``, vectorised over the outputs (one
            pass per tap), so it agrees with that loop *bit for bit*; slower (O(n·M)), and
            exactly 0 where the window sees only zeros. FFT rounding differs in principle;
            both agree to ~1e-13 relative.

        Returns
        -------
        ndarray, shape (n_samples - 2M, n_channels) or (n_samples - 2M,)
            Row j belongs to input sample j + M (see `output_time`); units of x per s^order.
            ``paper=True`` returns ``n_samples - 2M - 1`` rows.

        Examples
        --------
        >>> import numpy as np
        >>> f = design_filter("first", half_width=10, cutoff=0.5, dt=0.1)
        >>> t = 0.1 * np.arange(50)
        >>> bool(np.allclose(f.apply(3.0 * t + 1.0), 3.0))   # slope of a ramp
        True
        """
        if np.iscomplexobj(x):
            raise InputError("x must be real numbers; got a complex array. Filter .real and .imag.")
        if method not in ("fft", "direct"):
            raise InputError(f"method must be 'fft' or 'direct'; got {method!r}.")
        try:
            arr = np.asarray(x, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError(f"x must be real numbers; could not convert it ({exc}).") from None
        one_d = arr.ndim == 1
        if one_d:
            arr = arr[:, None]
        if arr.ndim != 2:
            raise ShapeError(
                f"x must have shape (n_samples, n_channels) or (n_samples,); got shape {arr.shape}."
            )
        n = arr.shape[0]
        self._check_length(n, paper)
        check_finite(arr, "x")
        if arr.shape[1] == 0:
            out = np.empty((n - 2 * self.half_width, 0))
        elif method == "fft":
            # correlation with c == convolution with c reversed; 'valid' keeps n - 2M rows.
            # Transposed so that each channel is one contiguous convolution (fastest layout).
            out = signal.oaconvolve(arr.T, self.taps[None, ::-1], mode="valid", axes=1).T
        else:  # "direct": y[j] = Σ_k x[j+k] taps[k], accumulated k = 0..2M left to right
            # (a BLAS dot or einsum may sum in blocks or use FMA: different last bits; this loop
            # runs over the 2M+1 taps, each pass vectorised over all samples and channels)
            n_out = n - 2 * self.half_width
            out = np.zeros((n_out, arr.shape[1]))
            for k, tap in enumerate(self.taps.tolist()):
                out += arr[k : k + n_out] * tap  # product rounded, then the sum: as in the loop
        if paper:
            out = out[:-1]
        out = np.ascontiguousarray(out)
        return out[:, 0] if one_d else out

    __call__ = apply

    def filter_signal(self, x, t, *, paper: bool = False, method: str = "fft") -> FilteredSignal:
        """Filter ``x`` and return the samples with their aligned time vector.

        Parameters
        ----------
        x : array_like, shape (n_samples, n_channels) or (n_samples,)
            Uniformly sampled signal.
        t : array_like, shape (n_samples,) [s]
            Its sample times, strictly increasing with period `dt` (relative tolerance 1e-6).
        paper : bool
            Drop one more sample at the end, like the paper.
        method : {"fft", "direct"}
            As in `apply`.

        Returns
        -------
        FilteredSignal
            ``t`` (n_out,) [s] and ``values`` (n_out, n_channels) or (n_out,) [unit of x per
            s^order], read-only, with ``n_out = n_samples - 2M`` (one fewer when ``paper``);
            ``values[j]`` belongs to input sample ``j + M`` at time ``t[j]``.

        Raises
        ------
        ShapeError
            ``x`` does not have one row per sample of ``t``.
        SamplingError
            ``t`` is not strictly increasing, not uniform, or its period is not `dt`; or the
            record is shorter than the filter.

        Examples
        --------
        The derivative of 3t + 1 is 3, at the times t[M:n-M]:

        >>> import numpy as np
        >>> f = design_filter("first", half_width=10, cutoff=0.5, dt=0.1)
        >>> t = 0.1 * np.arange(50)
        >>> out = f.filter_signal(3.0 * t + 1.0, t)
        >>> out.values.shape, float(out.t[0]), bool(np.allclose(out.values, 3.0))
        ((30,), 1.0, True)
        """
        t = check_time(t, "t")
        period = sample_period(t, "t")
        if not np.isclose(period, self.dt, rtol=1e-6, atol=0.0):
            raise SamplingError(
                f"t has sample period {period:.9g} s but the filter was designed for "
                f"dt = {self.dt:.9g} s; design the filter with dt={period:.9g} (e.g. "
                "design_filter(kind, M, cutoff, rec.dt)) or pass the matching time vector."
            )
        if np.shape(x)[:1] != t.shape:
            raise ShapeError(
                f"x must have one row per sample of t ({t.size}); got x of shape {np.shape(x)}."
            )
        values = self.apply(x, paper=paper, method=method)
        t_out = np.array(self.output_time(t, paper=paper))
        values.setflags(write=False)
        t_out.setflags(write=False)
        return FilteredSignal(t_out, values)

    # ------------------------------------------------------------------ frequency domain
    def frequency_response(self, omega) -> np.ndarray:
        """Complex response of the centred filter at ``omega`` [rad/sample].

        ``H(Ω) = Σ_n taps[n] e^{+jΩn}`` (correlation taps), which approximates ``(jΩ/Δ)^order``
        in the pass band; the M-sample delay of a causal implementation is not included.

        Parameters
        ----------
        omega : array_like, any shape [rad/sample]
            Normalised angular frequencies Ω = 2π f Δ.

        Returns
        -------
        ndarray of complex, same shape as ``omega`` [1/s^order]
            For a sinusoid ``x[i] = e^{jΩi}`` the output row belonging to sample i is
            ``H(Ω) e^{jΩi}``.

        Examples
        --------
        The first-derivative filter's response in the pass band is ``jΩ/Δ``:

        >>> f = design_filter("first", half_width=100, cutoff=0.2, dt=1e-3)
        >>> h = f.frequency_response(0.01)
        >>> bool(abs(h / (1j * 0.01 / 1e-3) - 1) < 1e-3)   # flat to 1e-3 below Ω_g/4
        True
        """
        omega = np.asarray(omega, dtype=float)
        n = np.arange(-self.half_width, self.half_width + 1)
        return np.exp(1j * omega[..., None] * n) @ self.taps.astype(complex)

    def ideal_response(self, omega) -> np.ndarray:
        """Ideal response ``(jΩ/Δ)^order`` for ``|Ω| <= Ω_g``, 0 beyond (omega in rad/sample).

        Parameters
        ----------
        omega : array_like, any shape [rad/sample]

        Returns
        -------
        ndarray of complex, same shape as ``omega`` [1/s^order]
        """
        omega = np.asarray(omega, dtype=float)
        ideal = (1j * omega / self.dt) ** self.order
        return np.where(np.abs(omega) <= self.cutoff, ideal, 0.0 + 0.0j)

    # ------------------------------------------------------------------ helpers
    def _check_length(self, n_samples: int, paper: bool) -> None:
        need = self.n_taps + (1 if paper else 0)
        check_length(
            n_samples,
            need,
            f"the {self.kind} filter with half_width={self.half_width} ({self.n_taps} taps"
            f"{', paper=True' if paper else ''})",
            "Use a longer record or a smaller half_width.",
        )

    def __repr__(self) -> str:
        return (
            f"DifferentialFilter(kind={self.kind!r}, half_width={self.half_width}, "
            f"cutoff={self.cutoff:g} rad/sample, dt={self.dt:g} s, delay={self.delay} samples)"
        )


def design_filter(kind, half_width: int, cutoff: float, dt: float) -> DifferentialFilter:
    """Design the paper's Harris-windowed low-pass (Filtr), d/dt (Filtr1) or d²/dt² (Filtr2) filter.

    Parameters
    ----------
    kind : {"lowpass", "first", "second"} or {0, 1, 2}
        What the filter estimates: the low-passed signal, its first or its second derivative.
    half_width : int
        M >= 1; the filter has 2M + 1 taps and delays by M samples (the paper uses M = 100).
    cutoff : float [rad/sample]
        Ω_g, 0 < Ω_g <= π (the paper uses 0.2, i.e. 0.2/(2πΔ) = 31.8 Hz at Δ = 1 ms).
    dt : float [s]
        Sample period Δ > 0.

    Returns
    -------
    DifferentialFilter

    Examples
    --------
    The second-derivative filter returns exactly 2 on t²:

    >>> import numpy as np
    >>> f = design_filter("second", half_width=20, cutoff=0.3, dt=0.01)
    >>> t = 0.01 * np.arange(100)
    >>> round(float(f.apply(t**2).mean()), 9)
    2.0
    """
    order = _check_kind(kind)
    m = _check_half_width(half_width)
    cutoff = _check_cutoff(cutoff)
    dt = _check_dt(dt)
    n = np.arange(-m, m + 1, dtype=float)
    window = harris_window(m)

    # Filtr: c0 = h0 w / κH1, κH1 = Σ h0 w  -> DC gain 1
    h0w = ideal_impulse_response(0, m, cutoff, dt) * window
    lowpass = h0w / np.sum(h0w)
    if order == 0:
        taps = lowpass
    elif order == 1:
        # Filtr1: κH2 = Σ h1 w (0 - nΔ);  c1 = h1 w · (-1/κH2)
        # -> correlation on a ramp: Σ c1[n] (t + nΔ) = 1
        h1w = ideal_impulse_response(1, m, cutoff, dt) * window
        kappa_h2 = np.sum(h1w * (0.0 - n * dt))
        taps = h1w * (-1.0 / kappa_h2)
    else:
        # Filtr2: remove the DC part with the low-pass, g = h2 w - κH3 c0, κH3 = Σ h2 w;
        # κH4 = Σ g (0 - (Δn)²);  c2 = -2 g / κH4  -> Σ c2[n] (t + nΔ)² = 2.
        # (The paper's "(0 - (Δn)²)" together with "-2/κH4" is what gives +2; reading it as
        # (0 - Δn)², like κH2, would flip the sign to -2.)
        h2w = ideal_impulse_response(2, m, cutoff, dt) * window
        kappa_h3 = np.sum(h2w)
        g = h2w - kappa_h3 * lowpass
        g = 0.5 * (g + g[::-1])  # exactly even (the rounding of the sums can break it at 1e-17)
        kappa_h4 = np.sum(g * (0.0 - (dt * n) ** 2))
        taps = (-2.0 / kappa_h4) * g
    taps = np.array(taps, dtype=float)
    taps.setflags(write=False)
    return DifferentialFilter(
        kind=_KIND_BY_ORDER[order], order=order, half_width=m, cutoff=cutoff, dt=dt, taps=taps
    )


@dataclass(frozen=True, eq=False)
class FilteredSignal:
    """One filter's output with its aligned time vector (see `DifferentialFilter.filter_signal`).

    Attributes
    ----------
    t : ndarray, shape (n_out,) [s]
        Time of each output row: the time of the input sample at the centre of its window.
    values : ndarray, shape (n_out, n_channels) or (n_out,) [unit of x per s^order]
        Filtered samples, read-only.
    """

    t: np.ndarray
    values: np.ndarray

    @property
    def n_samples(self) -> int:
        """Number of output rows, n_out."""
        return int(self.t.size)


@dataclass(frozen=True, eq=False)
class FilteredDerivatives:
    """Low-passed signal and its first and second derivative estimates, aligned in time.

    All arrays have ``n_samples - 2M`` rows, row j belonging to input sample j + M.

    Attributes
    ----------
    t : ndarray, shape (n_out,) [s]
        Times of the output rows.
    value, first, second : ndarray, shape (n_out, n_channels) or (n_out,)
        Low-passed x [unit of x], its first [unit/s] and second [unit/s²] derivatives.
    lowpass, first_filter, second_filter : DifferentialFilter
        The filters used (same M and Ω_g).
    """

    t: np.ndarray
    value: np.ndarray
    first: np.ndarray
    second: np.ndarray
    lowpass: DifferentialFilter = field(repr=False)
    first_filter: DifferentialFilter = field(repr=False)
    second_filter: DifferentialFilter = field(repr=False)

    @property
    def delay(self) -> int:
        """Delay [samples] common to the three estimates (M)."""
        return self.lowpass.delay

    @property
    def half_width(self) -> int:
        """M."""
        return self.lowpass.half_width

    @property
    def cutoff(self) -> float:
        """Ω_g [rad/sample]."""
        return self.lowpass.cutoff


#: Designs of a filter bank: the paper's three independent filters, or derivative filters built
#: from the low-pass so that F_k = s^k F0 holds in the pass band.
BANK_DESIGNS = ("paper", "consistent")


def design_filter_bank(
    half_width: int, cutoff: float, dt: float, design: str = "paper"
) -> tuple[DifferentialFilter, DifferentialFilter, DifferentialFilter]:
    """Low-pass, d/dt and d²/dt² filters with the same M and Ω_g, aligned on the same samples.

    Parameters
    ----------
    half_width : int
        M (each filter has 2M + 1 taps).
    cutoff : float [rad/sample]
        Ω_g of the low-pass filter.
    dt : float [s]
        Sample period Δ.
    design : {"paper", "consistent"}
        ``"paper"``: the paper's ``Filtr``, ``Filtr1``, ``Filtr2``, each windowed on its own ideal
        response. Their pass bands agree with ``s^k F0`` only to ~5e-4 (M = 100, Ω_g = 0.2),
        which biases an input-error fit of a small inertia (m1·l1² of the paper's arm) by ~3 %.
        ``"consistent"``: the derivative taps are computed from the low-pass taps ``c0`` by
        spectral differentiation, ``c_k[n] = (1/2π) ∫ (jΩ/Δ)^k H0(Ω) e^{-jΩn} dΩ`` (an FFT on a
        grid 64 times longer than the filter), truncated to 2M + 1 taps, symmetrised, and
        normalised like the paper's (exact slope on t, exactly 2 on t², zero on constants).
        They match ``s^k F0`` to ~3e-5 (M = 100) and ~1e-5 (M = 200) in the pass band.

    Returns
    -------
    (lowpass, first, second) : tuple of DifferentialFilter

    Examples
    --------
    >>> import numpy as np
    >>> lp, d1, d2 = design_filter_bank(50, 0.3, 0.01, design="consistent")
    >>> t = 0.01 * np.arange(300)
    >>> bool(np.allclose(d2.apply(t**2), 2.0)), bool(np.allclose(d1.apply(t), 1.0))
    (True, True)
    """
    if design not in BANK_DESIGNS:
        raise InputError(f"design must be one of {BANK_DESIGNS}; got {design!r}.")
    lowpass = design_filter("lowpass", half_width, cutoff, dt)
    if design == "paper":
        return (
            lowpass,
            design_filter("first", half_width, cutoff, dt),
            design_filter("second", half_width, cutoff, dt),
        )
    m, dt = lowpass.half_width, lowpass.dt
    n = np.arange(-m, m + 1)
    n_fft = 1 << int(np.ceil(np.log2(64 * lowpass.n_taps)))
    omega = 2.0 * np.pi * np.fft.fftfreq(n_fft)
    padded = np.zeros(n_fft)
    padded[n % n_fft] = lowpass.taps
    h0 = np.fft.ifft(padded) * n_fft  # H0(Ω_j) = Σ c0[n] e^{jΩ_j n}
    bank = [lowpass]
    for order, kind in ((1, "first"), (2, "second")):
        # c_k[n] = (1/N) Σ_j (jΩ_j/Δ)^k H0(Ω_j) e^{-jΩ_j n}; ifft gives e^{+jΩ m}, so read m = -n
        ck = np.fft.ifft((1j * omega / dt) ** order * h0)[(-n) % n_fft].real
        if order == 1:
            ck = 0.5 * (ck - ck[::-1])  # odd
            ck /= ck @ (n * dt)  # Σ c1[n] (nΔ) = 1: exact slope on a ramp
        else:
            ck = 0.5 * (ck + ck[::-1])  # even
            ck -= ck.sum() * lowpass.taps  # zero DC, as the paper's κH3 correction
            ck *= 2.0 / (ck @ (n * dt) ** 2)  # Σ c2[n] (nΔ)² = 2: exact on t²
        ck.setflags(write=False)
        bank.append(
            DifferentialFilter(
                kind=kind, order=order, half_width=m, cutoff=lowpass.cutoff, dt=dt, taps=ck
            )
        )
    return tuple(bank)


def filter_derivatives(
    x, t, half_width: int, cutoff: float, *, paper: bool = False, design: str = "paper"
) -> FilteredDerivatives:
    """Low-pass ``x`` and estimate its first and second time derivatives with the same M and Ω_g.

    Parameters
    ----------
    x : array_like, shape (n_samples, n_channels) or (n_samples,)
        Signal samples.
    t : array_like, shape (n_samples,) [s]
        Uniformly spaced sample times.
    half_width : int
        M (filters have 2M + 1 taps).
    cutoff : float [rad/sample]
        Ω_g.
    paper : bool
        Drop one more sample at the end, like the paper.
    design : {"paper", "consistent"}
        Which filter bank (see `design_filter_bank`).

    Returns
    -------
    FilteredDerivatives
        ``t``, ``value``, ``first``, ``second`` aligned on the same output times.

    Examples
    --------
    >>> import numpy as np
    >>> t = 0.01 * np.arange(200)
    >>> d = filter_derivatives(t**3, t, half_width=20, cutoff=0.3)
    >>> bool(np.allclose(d.second, 6 * d.t))
    True
    """
    t = check_time(t, "t")
    dt = sample_period(t, "t")
    arr = np.asarray(x, dtype=float)
    if arr.shape[:1] != t.shape:
        raise ShapeError(
            f"x must have one row per sample of t ({t.size}); got x of shape {arr.shape}."
        )
    filters = design_filter_bank(half_width, cutoff, dt, design)
    outputs = [f.apply(arr, paper=paper) for f in filters]
    for out in outputs:
        out.setflags(write=False)
    t_out = filters[0].output_time(t, paper=paper)
    t_out.setflags(write=False)
    return FilteredDerivatives(t_out, *outputs, *filters)


# ---------------------------------------------------------------------- validation helpers
def _check_kind(kind) -> int:
    if isinstance(kind, str):
        key = kind.strip().lower().replace("-", "").replace("_", "")
        if key in KINDS:
            return KINDS[key]
    elif isinstance(kind, numbers.Integral) and not isinstance(kind, bool):
        if int(kind) in _KIND_BY_ORDER:
            return int(kind)
    raise InputError(
        "kind must be 'lowpass', 'first' or 'second' (or 0, 1, 2, the derivative order); "
        f"got {kind!r}."
    )


def _check_half_width(half_width) -> int:
    return check_int(
        half_width,
        "half_width",
        minimum=1,
        fix="It is M: the filter has 2M + 1 taps; the paper uses M = 100.",
    )


def _check_cutoff(cutoff) -> float:
    try:
        value = float(cutoff)
    except (TypeError, ValueError):
        raise InputError(f"cutoff (Ω_g, rad/sample) must be a number; got {cutoff!r}.") from None
    if not (np.isfinite(value) and 0.0 < value <= np.pi):
        raise InputError(
            f"cutoff (Ω_g, rad/sample) must lie in (0, π]; got {cutoff!r}. It is a normalised "
            "frequency: Ω_g = 2π f_c Δ for a cut-off f_c [Hz] at sample period Δ [s] "
            "(the paper uses 0.2)."
        )
    return value


def _check_dt(dt) -> float:
    try:
        value = float(dt)
    except (TypeError, ValueError):
        raise InputError(f"dt (sample period, s) must be a number; got {dt!r}.") from None
    if not (np.isfinite(value) and value > 0):
        raise InputError(
            f"dt (sample period, s) must be finite and > 0; got {dt!r}. Pass the recording's "
            "sample period, e.g. rec.dt."
        )
    return value
