"""Exact sampled simulation of linear ODE models ``Σ_i a_i y^(i) = Σ_j b_j u^(j)`` (any order).

How it works
------------
The model is realised in controllable canonical form ``ż = A z + B u``, ``y = C z + D u``. The
input is the output of a small *exogenous* linear system ``ẇ = S w``, ``u = E w``:

* a sinusoid ``A1 sin(ω t + φ)``: ``w = (sin(ωt+φ), cos(ωt+φ))``, ``S = [[0, ω], [−ω, 0]]``
  (one such block per component of a multisine), so the sampled response is *exact*;
* a sampled input held between samples: zero-order hold ``w = u_k`` (``S = 0``), or first-order
  hold (linear between samples) ``w = (u(t), s_k)``, ``s_k = (u_{k+1} − u_k)/Δ``.

Over a step τ the augmented system ``[ż; ẇ] = F [z; w]``, ``F = [[A, B E], [0, S]]``, is solved by
one matrix exponential ``expm(F τ) = [[Φ, Γ], [0, ·]]``: ``z(t+τ) = Φ z(t) + Γ w(t)``. Φ and Γ are
computed once per parameter segment; the recursion ``z_{k+1} = Φ z_k + Γ w_k`` over the samples
is run in the complex Schur basis of Φ (``Φ = Q T Qᴴ``, Q unitary, T upper triangular), where it
is a cascade of first-order recursions, each one `scipy.signal.lfilter` call (no Python loop over
samples, exact for repeated poles, no ill-conditioned eigenvector basis).

Initial conditions and parameter jumps are stated in *output derivatives* ``(y, ẏ, …, y^(n−1))``:
``y^(k) = [C, D E] F^k [z; w]`` maps the realisation state to them (the observability matrix of
the augmented pair), so they do not depend on the realisation. At a parameter jump these output
derivatives are kept continuous (for the mass-spring-damper: position and velocity), and the new
realisation's state is solved from them. This is the paper's Fig. 16 experiment (Oueslati et al.
2011, section 5.C): piecewise-constant ω0 with a continuous motion.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg import expm, matrix_balance, schur
from scipy.signal import lfilter

from .._validate import as_1d, check_finite, check_positive, check_time, sample_period
from ..errors import InputError, SamplingError, ShapeError, SimulationError
from ..models.linear_ode import linear_ode_state_space, normalised_coefficients
from ..signals.excitation import Multisine, Sinusoid
from ..signals.noise import add_white_noise, alias_frequency, make_rng, sinusoidal_disturbance
from .recordings import LinearODERecording

__all__ = [
    "simulate_linear_ode",
    "linear_ode_state_space",
    "uniform_time",
]

_HOLDS = ("zoh", "foh")


# --------------------------------------------------------------------------- coefficients
class _CoefficientSource:
    """Turns (model, params) into normalised ``(a, b)`` for each parameter segment."""

    def __init__(self, model) -> None:
        self.model = model
        self.is_model = hasattr(model, "coefficients")
        if not self.is_model:
            if not (isinstance(model, Sequence) and len(model) == 2):
                raise InputError(
                    "model must be a linear ODE model (with a coefficients(params) method, e.g. "
                    "physid.load_model('msd')) or a pair (a, b) of coefficient arrays in ascending "
                    f"derivative order; got {type(model).__name__}."
                )
            normalised_coefficients(model[0], model[1], "model")

    def initial(self, params):
        """Full parameter set of the first segment."""
        if not self.is_model:
            if params is not None:
                raise InputError(
                    "params must be None when the model is given as coefficient arrays (a, b); "
                    "pass the coefficients you want as the model instead."
                )
            return (self.model[0], self.model[1])
        if params is None:
            return dict(self.model.parameters)
        if isinstance(params, Mapping):
            full = dict(self.model.parameters)
            unknown = sorted(set(params) - set(full))
            if unknown:
                raise InputError(
                    f"params names unknown parameter(s) {unknown}; the model has {sorted(full)}."
                )
            full.update({k: float(v) for k, v in params.items()})
            return full
        return np.asarray(params, dtype=float)

    def updated(self, current, change, when: float):
        """Parameters after a jump: a mapping updates a model's parameters; a pair replaces "
        "(a, b)."""
        if not self.is_model:
            if not (isinstance(change, Sequence) and len(change) == 2):
                raise InputError(
                    f"the jump at t = {when} s must give new coefficients (a, b) when the "
                    "model is a "
                    f"coefficient pair; got {change!r}."
                )
            return (change[0], change[1])
        if not isinstance(change, Mapping):
            raise InputError(
                f"the jump at t = {when} s must be a mapping parameter name -> new value; got "
                f"{change!r}."
            )
        if not isinstance(current, dict):
            names = (
                list(self.model.parameter_names) if hasattr(self.model, "parameter_names") else None
            )
            if names is None:
                raise InputError("jumps need params given as a mapping for this model.")
            current = dict(zip(names, np.asarray(current, dtype=float), strict=True))
        unknown = sorted(set(change) - set(current))
        if unknown:
            raise InputError(
                f"the jump at t = {when} s names unknown parameter(s) {unknown}; known: "
                f"{sorted(current)}."
            )
        out = dict(current)
        out.update({k: float(v) for k, v in change.items()})
        return out

    def coefficients(self, params, where: str) -> tuple[np.ndarray, np.ndarray]:
        if not self.is_model:
            return normalised_coefficients(params[0], params[1], where)
        a, b = self.model.coefficients(params)
        return normalised_coefficients(a, b, where)


# --------------------------------------------------------------------------- exogenous input
class _SineInput:
    """Sum of sinusoids generated exactly: w = (sin θ_1, cos θ_1, sin θ_2, ...), θ_k = ω_k t "
    "+ φ_k."""

    exact = True

    def __init__(self, components) -> None:
        comps = np.asarray(components, dtype=float).reshape(-1, 3)
        self.amplitudes, self.omegas, self.phases = comps.T
        p = 2 * comps.shape[0]
        self.S = np.zeros((p, p))
        self.E = np.zeros(p)
        for k, (amp, w, _) in enumerate(comps):
            self.S[2 * k, 2 * k + 1] = w  # d/dt sin θ = ω cos θ
            self.S[2 * k + 1, 2 * k] = -w  # d/dt cos θ = −ω sin θ
            self.E[2 * k] = amp

    def state_at(self, times: np.ndarray) -> np.ndarray:
        theta = np.asarray(times, dtype=float)[:, None] * self.omegas + self.phases
        w = np.empty((theta.shape[0], 2 * theta.shape[1]))
        w[:, 0::2] = np.sin(theta)
        w[:, 1::2] = np.cos(theta)
        return w

    def grid_state(self, t: np.ndarray, ks: slice) -> np.ndarray:
        return self.state_at(t[ks])

    def values(self, t: np.ndarray) -> np.ndarray:
        return self.state_at(t) @ self.E


class _HeldInput:
    """Samples ``u_k`` on the grid, held by zero order (constant) or first order (linear)."""

    exact = False

    def __init__(self, t: np.ndarray, u: np.ndarray, hold: str) -> None:
        self.t = t
        self.u = u
        self.hold = hold
        if hold == "zoh":
            self.S = np.zeros((1, 1))
            self.E = np.ones(1)
        else:
            self.S = np.array([[0.0, 1.0], [0.0, 0.0]])  # u̇ = s, ṡ = 0 between samples
            self.E = np.array([1.0, 0.0])
            slopes = np.zeros_like(u)
            slopes[:-1] = np.diff(u) / np.diff(t)
            self.slopes = slopes

    def state_at(self, times: np.ndarray) -> np.ndarray:
        times = np.asarray(times, dtype=float)
        k = np.clip(np.searchsorted(self.t, times, side="right") - 1, 0, self.t.size - 1)
        if self.hold == "zoh":
            return self.u[k][:, None]
        return np.column_stack([self.u[k] + self.slopes[k] * (times - self.t[k]), self.slopes[k]])

    def grid_state(self, t: np.ndarray, ks: slice) -> np.ndarray:
        if self.hold == "zoh":
            return self.u[ks][:, None]
        return np.column_stack([self.u[ks], self.slopes[ks]])

    def values(self, t: np.ndarray) -> np.ndarray:
        return self.u.copy()


def _make_input(inp, t: np.ndarray, hold: str):
    if hold not in _HOLDS:
        raise InputError(
            f"hold must be 'zoh' (zero-order) or 'foh' (first-order/linear); got {hold!r}."
        )
    if isinstance(inp, (Sinusoid, Multisine)):
        return _SineInput(inp.components)
    if inp is None:
        return _HeldInput(t, np.zeros_like(t), "zoh")
    if callable(inp):
        u = as_1d(inp(t.copy()), "input(t)")
        if u.size == 1:
            u = np.full_like(t, u[0])
    else:
        u = as_1d(inp, "input")
        if u.size == 1:
            u = np.full_like(t, u[0])
    if u.size != t.size:
        raise ShapeError(
            f"the sampled input must have one value per time sample ({t.size}); got {u.size}. "
            "Pass a Sinusoid/Multisine for exact simulation, a callable u(t), or an array on "
            "the grid."
        )
    check_finite(u[:, None], "input")
    return _HeldInput(t, u, hold)


# --------------------------------------------------------------------------- numerics
@dataclass(frozen=True)
class _Segment:
    """One parameter segment: realisation, augmented matrix and output-derivative map."""

    a: np.ndarray
    b: np.ndarray
    A: np.ndarray
    C: np.ndarray
    D: float
    F: np.ndarray
    O_state: np.ndarray  # (n, n)   y^(k) = O_state z + O_input w
    O_input: np.ndarray  # (n, p)

    @property
    def n(self) -> int:
        return self.A.shape[0]

    def step(self, tau: float) -> tuple[np.ndarray, np.ndarray]:
        """``(Φ, Γ)`` with ``z(t + τ) = Φ z(t) + Γ w(t)``."""
        n = self.n
        if tau == 0.0:
            return np.eye(n), np.zeros((n, self.F.shape[0] - n))
        e = expm(self.F * tau)
        return e[:n, :n], e[:n, n:]

    def state_from_derivatives(self, d: np.ndarray, w: np.ndarray) -> np.ndarray:
        return np.linalg.solve(self.O_state, d - self.O_input @ w)

    def derivatives(self, z: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Output derivatives for states z (k, n) and inputs w (k, p) -> (k, n)."""
        return _rows_times(z, self.O_state) + _rows_times(w, self.O_input)


def _segment(a, b, exo) -> _Segment:
    A, B, C, D = linear_ode_state_space(a, b)
    # Companion matrices of models with widely spread coefficients are badly scaled; a diagonal
    # similarity z = T z' with powers of two (exact in floating point) balances A, so that expm
    # and the recursion keep full relative accuracy (the results are realisation-independent:
    # states enter and leave only through the output derivatives).
    _, (scale, _) = matrix_balance(A, permute=False, separate=True)
    A = A * (1.0 / scale)[:, None] * scale[None, :]  # T⁻¹ A T
    B = B / scale  # T⁻¹ B
    C = C * scale  # C T
    n = A.shape[0]
    p = exo.S.shape[0]
    F = np.zeros((n + p, n + p))
    F[:n, :n] = A
    F[:n, n:] = np.outer(B, exo.E)
    F[n:, n:] = exo.S
    row = np.concatenate([C, D * exo.E])  # y = [C, D E] [z; w]
    rows = []
    for _ in range(n):
        rows.append(row)
        row = row @ F  # y^(k+1) = [C, D E] F^(k+1) [z; w]
    O = np.array(rows)
    O_state, O_input = O[:, :n], O[:, n:]
    # The output derivatives determine the state unless B(s) = Σ b_j s^j vanishes at a pole
    # (O_state is then singular). Test |B(p)| relative to Σ |b_j| |p|^j: free of units/scaling.
    poles = np.roots(a[::-1])
    powers = poles[:, None] ** np.arange(b.size)
    relative = np.abs(powers @ b) / np.maximum(np.abs(powers) @ np.abs(b), np.finfo(float).tiny)
    if b.size > 1 and np.any(relative < 1e-9):
        raise InputError(
            f"the model with a = {a.tolist()}, b = {b.tolist()} has a numerator and "
            "denominator with a "
            "common root (pole-zero cancellation), so its output derivatives do not determine its "
            "state; cancel the common factor first."
        )
    return _Segment(a, b, A, C, D, F, O_state, O_input)


def _rows_times(X: np.ndarray, M: np.ndarray) -> np.ndarray:
    """``X @ M.T`` for a tall X (N, p) and a tiny M (q, p), as p broadcast multiply-adds.

    BLAS is slow and multi-threaded for such shapes (inner dimension 1..4); the columns loop runs
    over the model order, not over samples.
    """
    out = np.zeros((X.shape[0], M.shape[0]), dtype=np.result_type(X, M))
    for j in range(X.shape[1]):
        out += X[:, j : j + 1] * M[:, j]
    return out


def _recurse(Phi: np.ndarray, Gamma: np.ndarray, z0: np.ndarray, W: np.ndarray) -> np.ndarray:
    """States ``z_0 .. z_K`` of ``z_{k+1} = Φ z_k + Γ w_k`` for inputs W (K, p); returns (K+1, n).

    Φ = Q T Qᴴ (complex Schur): with η = Qᴴ z the recursion is triangular,
    ``η_{k+1,i} = T_ii η_{k,i} + Σ_{j>i} T_ij η_{k,j} + (QᴴΓ w_k)_i``, solved from the last
    component up, each as one first-order IIR filter (lfilter) over the whole record.
    """
    n = Phi.shape[0]
    n_steps = W.shape[0]
    if n_steps == 0:
        return z0[None, :].copy()
    T, Q = schur(Phi, output="complex")
    eta0 = Q.conj().T @ z0
    beta = _rows_times(W, Q.conj().T @ Gamma)  # row k = (Qᴴ Γ w_k)ᵀ
    eta = np.empty((n_steps + 1, n), dtype=complex)
    for i in range(n - 1, -1, -1):
        forcing = beta[:, i].copy()
        for j in range(i + 1, n):
            forcing += T[i, j] * eta[:-1, j]
        # lfilter(1, [1, −λ]) computes y_k = v_k + λ y_{k−1}; v_0 = η_0 seeds the recursion.
        drive = np.concatenate(([eta0[i]], forcing))
        eta[:, i] = lfilter([1.0], [1.0, -T[i, i]], drive)
    return _rows_times(eta, Q).real  # z_k = Q η_k


# --------------------------------------------------------------------------- public API
def uniform_time(t=None, *, duration=None, dt=None, t0: float = 0.0) -> np.ndarray:
    """A uniform time grid [s]: ``t`` itself (checked), or ``t0 + Δ·k`` for k = 0 .. duration/Δ.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s], optional
        An existing grid; it is checked (finite, strictly increasing, uniform) and returned.
        Give either `t` or both `duration` and `dt`.
    duration : float [s], optional
        Length of the grid; must be a whole number of periods `dt` (to 1e-9 relative), so the
        last sample is at ``t0 + duration``.
    dt : float [s], optional
        Sample period Δ > 0.
    t0 : float [s]
        Time of the first sample (default 0).

    Returns
    -------
    ndarray, shape (n_samples,) [s]
        ``t0 + dt * arange(round(duration / dt) + 1)``, or the checked `t`.

    Raises
    ------
    InputError
        Both or neither of `t` and (`duration`, `dt`) given; non-positive `duration`/`dt`.
    SamplingError
        `duration` is not a whole number of periods, or `t` is not uniform.

    Examples
    --------
    The paper's MSD record, 5 s at Δ = 1 ms, has 5001 samples ending at 5 s:

    >>> t = uniform_time(duration=5.0, dt=1e-3)
    >>> t.size, float(t[-1])
    (5001, 5.0)
    """
    if t is not None:
        if duration is not None or dt is not None:
            raise InputError("give either t or (duration, dt), not both.")
        t = check_time(t, "t")
        sample_period(t, "t")
        return t
    if duration is None or dt is None:
        raise InputError("give the time grid as t, or as both duration [s] and dt [s].")
    duration = check_positive(duration, "duration")
    dt = check_positive(dt, "dt")
    steps = duration / dt
    n_steps = int(round(steps))
    if n_steps < 1 or abs(steps - n_steps) > 1e-9 * max(1.0, steps):
        raise SamplingError(
            f"duration = {duration} s is not a whole number of sample periods dt = {dt} s "
            f"(ratio {steps:.12g}); choose duration as a multiple of dt."
        )
    return float(t0) + dt * np.arange(n_steps + 1)


def _parameter_segments(source, t, params, jumps, exo) -> tuple[list[_Segment], list[float]]:
    """The segments of constant parameters, split at the jumps, and their start times.

    Raises `InputError` for a malformed jump, a jump outside ``(t[0], t[-1]]``, two jumps at
    one time, or a jump that changes the model's order.
    """
    current = source.initial(params)
    seg_params = [current]
    seg_starts = [float(t[0])]
    for item in sorted(jumps or (), key=lambda j: float(j[0])):
        try:
            when, change = item
            when = float(when)
        except (TypeError, ValueError):
            raise InputError(
                f"each jump must be a pair (time [s], change); got {item!r}."
            ) from None
        if not (t[0] < when <= t[-1]):
            raise InputError(
                f"jump time {when} s lies outside the simulated interval ({t[0]}, {t[-1]}] s; "
                "drop it or extend the time grid."
            )
        if when == seg_starts[-1]:
            raise InputError(f"two jumps at the same time {when} s; merge them into one change.")
        current = source.updated(current, change, when)
        seg_params.append(current)
        seg_starts.append(when)
    segments = []
    for i, p in enumerate(seg_params):
        a, b = source.coefficients(p, f"segment {i} (from t = {seg_starts[i]} s)")
        segments.append(_segment(a, b, exo))
    n = segments[0].n
    if any(s.n != n for s in segments):
        raise InputError(
            "a jump changed the model order; jumps may change coefficient values only."
        )
    return segments, seg_starts


def _initial_derivatives(x0, exo, t: np.ndarray, first: _Segment) -> np.ndarray:
    """The initial output derivatives: ``x0``, or those of the zero realisation state."""
    n = first.n
    if x0 is None:  # at rest: zero realisation state (for m = 0 the same as zero derivatives)
        w0 = exo.state_at(t[:1])
        d0 = first.derivatives(np.zeros((1, n)), w0)[0]
    else:
        d0 = as_1d(x0, "x0")
    if d0.size != n:
        raise ShapeError(
            f"x0 must hold the {n} initial output derivatives (x, ẋ, …, x^({n - 1})); got "
            f"{d0.size} values."
        )
    check_finite(d0[:, None], "x0")
    return d0


def _integrate(segments, seg_starts, exo, t: np.ndarray, period: float, d0) -> np.ndarray:
    """The output derivatives at every sample, segment by segment (exact discretisation).

    The output derivatives are carried across each jump, so they stay continuous.
    """
    n = segments[0].n
    derivs = np.empty((t.size, n))
    d_at_start = d0
    seg_ends = seg_starts[1:] + [np.inf]
    for seg, start, end in zip(segments, seg_starts, seg_ends, strict=True):
        w_start = exo.state_at(np.array([start]))[0]
        z_start = seg.state_from_derivatives(d_at_start, w_start)
        k0 = int(np.searchsorted(t, start, side="left"))  # first sample at or after the start
        k1 = int(np.searchsorted(t, end, side="left"))  # first sample of the next segment
        if k1 > k0:
            phi_p, gamma_p = seg.step(float(t[k0] - start))
            z_first = phi_p @ z_start + gamma_p @ w_start
            W = exo.grid_state(t, slice(k0, k1))
            phi, gamma = seg.step(period)
            z = _recurse(phi, gamma, z_first, W[:-1])
            derivs[k0:k1] = seg.derivatives(z, W)
            if np.isfinite(end):  # propagate from the last sample of the segment to the jump
                phi_e, gamma_e = seg.step(float(end - t[k1 - 1]))
                z_end = phi_e @ z[-1] + gamma_e @ W[-1]
        elif np.isfinite(end):  # two jumps within one sample period
            phi_e, gamma_e = seg.step(float(end - start))
            z_end = phi_e @ z_start + gamma_e @ w_start
        if np.isfinite(end):
            w_end = exo.state_at(np.array([end]))[0]
            d_at_start = seg.derivatives(z_end[None, :], w_end[None, :])[0]
    return derivs


def _measure(
    x_clean, t, period, snr_db, noise_std, disturbance, rng, meta
) -> tuple[np.ndarray, bool]:
    """The measured x: the clean one plus the noise and the disturbance asked for.

    Their description goes into ``meta``. Returns the measured x and whether noise was added.
    """
    x_meas = x_clean.copy()
    if snr_db is not None and noise_std is not None:
        raise InputError(
            f"give at most one of snr_db and noise_std; got {snr_db!r} and {noise_std!r}."
        )
    noisy = snr_db is not None or noise_std is not None
    if noisy:
        seed_info = rng if isinstance(rng, (int, np.integer)) else None
        generator = make_rng(rng)
        if snr_db is not None:
            x_meas, noise = add_white_noise(x_clean, snr_db=snr_db, rng=generator)
        else:
            x_meas, noise = add_white_noise(x_clean, std=noise_std, rng=generator)
        meta["noise"] = {
            "kind": "white Gaussian, added to x",
            "snr_db_requested": None if snr_db is None else float(snr_db),
            "std_requested": None if noise_std is None else float(noise_std),
            "std_realised": float(np.std(noise)),
            "snr_db_realised": float(10 * np.log10(np.sum(x_clean**2) / np.sum(noise**2)))
            if np.any(noise) and np.any(x_clean)
            else None,
            "seed": None if seed_info is None else int(seed_info),
            "snr_definition": "10 log10(sum x_true^2 / sum noise^2) over the record",
        }
    if disturbance is not None:
        try:
            amp2, omega2 = (float(v) for v in disturbance)
        except (TypeError, ValueError):
            raise InputError(
                "disturbance must be a pair (amplitude, angular_frequency [rad/s]); got "
                f"{disturbance!r}."
            ) from None
        x_meas = x_meas + sinusoidal_disturbance(t, amp2, omega2)
        meta["disturbance"] = {
            "amplitude": amp2,
            "angular_frequency": omega2,
            "alias_angular_frequency": alias_frequency(omega2, period),
            "nyquist_angular_frequency": np.pi / period,
        }
    return x_meas, noisy


def _columns(u, x_meas, x_clean, derivs, with_true: bool, output_derivatives: bool, units):
    """The recording's channels and their units."""
    n = derivs.shape[1]
    units = dict(units or {})
    columns = {"u": u, "x": x_meas}
    if with_true:
        columns["x_true"] = x_clean
    if output_derivatives:
        for k in range(1, n):
            columns[f"x_d{k}"] = derivs[:, k]
    unit_map = {
        name: units.get(name, units.get("x", "") if name.startswith("x") else "")
        for name in columns
    }
    for k in range(1, n if output_derivatives else 1):
        base = units.get("x", "")
        unit_map[f"x_d{k}"] = f"{base}/s^{k}" if base and k > 1 else (f"{base}/s" if base else "")
    return columns, unit_map


def simulate_linear_ode(
    model,
    t=None,
    *,
    duration: float | None = None,
    dt: float | None = None,
    t0: float = 0.0,
    input: Sinusoid | Multisine | Callable | np.ndarray | float | None = None,  # noqa: A002
    hold: str = "foh",
    x0=None,
    params=None,
    jumps: Sequence[tuple[float, Any]] | None = None,
    snr_db: float | None = None,
    noise_std: float | None = None,
    disturbance: tuple[float, float] | None = None,
    rng=None,
    output_derivatives: bool = False,
    units: Mapping[str, str] | None = None,
    metadata: Mapping[str, Any] | None = None,
) -> LinearODERecording:
    """Simulate a linear ODE model ``Σ a_i x^(i) = Σ b_j u^(j)`` on a uniform grid.

    Parameters
    ----------
    model : LinearODEModel or (a, b)
        A model with ``coefficients(params) -> (a, b)`` and ``parameters`` (e.g.
        ``physid.load_model("msd")``), or coefficient arrays in ascending derivative order
        (``a = (a_0, …, a_n)``, ``b = (b_0, …, b_m)``, m <= n).
    t : array_like, shape (n_samples,) [s], optional
        Uniform sample times; or give ``duration`` and ``dt`` (and ``t0``).
    input : Sinusoid, Multisine, callable, array or float, optional
        The right-hand-side input u. A `Sinusoid`/`Multisine` is simulated *exactly* (the
        generator is part of the exponentiated system). A callable ``u(t)`` is sampled on the grid,
        and an array (one value per sample) or a constant is taken as samples; these are held
        between samples by ``hold``. ``None``: no input (free response).
    hold : {"foh", "zoh"}
        For sampled inputs: first-order hold (u linear between samples, as `scipy.signal.lsim`)
        or zero-order hold (u constant over each period).
    x0 : array_like, shape (n,), optional
        Initial output derivatives ``(x, ẋ, …, x^(n−1))`` at the first sample. Default: at rest
        (zero state of the realisation, as `scipy.signal.lsim`); for models without input
        derivatives (m = 0, e.g. the MSD) that is the same as all initial derivatives zero.
    params : mapping or array, optional
        Parameters of the first segment (a partial mapping overrides the model's nominal values).
    jumps : sequence of (time [s], change), optional
        Piecewise-constant parameters: from ``time`` on, the mapping ``change`` updates the
        parameters (for a coefficient-pair model, ``change`` is the new pair ``(a, b)``). The
        output derivatives ``x .. x^(n−1)`` stay continuous across a jump. Times must lie in
        ``(t[0], t[-1]]``.
    snr_db : float [dB], optional
        Add white Gaussian noise to x at this SNR, ``10 log10(Σ x² / Σ noise²)`` (of the clean x).
    noise_std : float, optional
        Add white Gaussian noise of this standard deviation (unit of x) instead.
    disturbance : (amplitude, angular_frequency [rad/s]), optional
        Add ``A2 sin(ω2 t)`` to the measured x (Oueslati et al. 2011, section 5.B). Not counted in
        the SNR. Above the Nyquist frequency it aliases (see
        `physid.signals.noise.alias_frequency`).
    rng : None, int, SeedSequence or Generator
        Noise source; the same seed gives the same bits.
    output_derivatives : bool
        Also return the clean derivatives ``x_d1 .. x_d{n−1}`` (k-th time derivative of x).
    units : mapping, optional
        Units of ``u`` and ``x`` (default ``""``).
    metadata : mapping, optional
        Extra metadata stored on the recording.

    Returns
    -------
    LinearODERecording
        A `Recording` whose ``plot()`` draws input and response. Channels ``u``, ``x``
        (measured: clean + noise + disturbance), ``x_true`` (clean, present when noise or a
        disturbance was added), and optionally ``x_d1 ..``.

    Examples
    --------
    Free oscillation of ẍ + x = 0 from x(0) = 1: x = cos t.

    >>> rec = simulate_linear_ode(([1.0, 0.0, 1.0], [1.0]), duration=np.pi, dt=np.pi / 4, x0=[1, 0])
    >>> np.round(rec["x"], 12).tolist()
    [1.0, 0.707106781187, 0.0, -0.707106781187, -1.0]
    """
    if rng is not None and snr_db is None and noise_std is None:
        raise InputError(
            f"rng={rng!r} only seeds the measurement noise, and none was asked for; give "
            "snr_db or noise_std, or drop the seed (the simulation itself is deterministic)."
        )
    source = _CoefficientSource(model)
    t = uniform_time(t, duration=duration, dt=dt, t0=t0)
    period = sample_period(t, "t")
    exo = _make_input(input, t, hold)

    segments, seg_starts = _parameter_segments(source, t, params, jumps, exo)
    d0 = _initial_derivatives(x0, exo, t, segments[0])
    derivs = _integrate(segments, seg_starts, exo, t, period, d0)
    x_clean = derivs[:, 0]
    u = exo.values(t)
    if not np.all(np.isfinite(x_clean)):
        raise SimulationError(
            "the simulated output overflowed: the model is unstable on this horizon. Shorten the "
            "duration or check the signs of the coefficients."
        )

    # ---- metadata, then the measurement (noise, disturbance)
    meta: dict[str, Any] = {
        "simulator": "physid.simulate.simulate_linear_ode",
        "method": "exact (sinusoid generator in the matrix exponential)"
        if exo.exact
        else f"{exo.hold} hold",
        "dt": period,
        "x0": d0.tolist(),
        "segments": [
            {"from": s0, "a": seg.a.tolist(), "b": seg.b.tolist()}
            for s0, seg in zip(seg_starts, segments, strict=True)
        ],
    }
    if exo.exact:
        meta["input_components"] = [
            {"amplitude": float(A), "angular_frequency": float(w), "phase": float(p)}
            for A, w, p in zip(exo.amplitudes, exo.omegas, exo.phases, strict=True)
        ]
    x_meas, noisy = _measure(x_clean, t, period, snr_db, noise_std, disturbance, rng, meta)
    meta.update(dict(metadata or {}))

    columns, unit_map = _columns(
        u, x_meas, x_clean, derivs, noisy or disturbance is not None, output_derivatives, units
    )
    return LinearODERecording.from_columns(t, columns, units=unit_map, metadata=meta)
