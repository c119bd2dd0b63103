"""The algebraic estimator's settings and its plan: everything fixed before the data arrive."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..._validate import check_positive
from ...errors import InputError, SamplingError, arg
from ...models.linear_ode import as_linear_ode_model
from .._linear import check_known_finite
from .._regression import offset_name
from .kernels import DEFAULT_INTERPOLATION_DEGREE, INTEGRATION_RULES, _taps_for

#: Default guard threshold: a window is invalid when its determinant level is below this fraction
#: of the median level over the trailing `guard_window` windows.
DEFAULT_GUARD = 0.1


FINAL_RULES = ("median", "lstsq", "bias-compensated")


#: Largest ``mu`` (smallest power ``ν`` of ``1/s``; with ``n_equations`` the largest power used)
#: the kernel construction supports. The kernels are polynomials of degree about ``ν + N + n`` in
#: the monomial basis; their coefficients grow like binomial coefficients and cancel in the
#: quadrature. Measured on the noise-free paper MSD (2 s at 1 kHz, T = 0.05 s / 0.2 s), the relative
#: error of ω0 is 1e-14 at ν = 3, 1e-10 at 10, 8e-8 / 7e-10 at 20, 2e-5 / 4e-7 at 25, 3e-3 / 1e-4
#: at 30, 0.19 / 9e-3 at 35 and 4.2 / NaN at 40 (``mu = 40`` gives ω0 = 64.7 for 11.55).
#: `MAX_MU` = 20 keeps the arithmetic's share of the error below 1e-7; larger values are refused.
MAX_MU = 20


@dataclass(frozen=True)
class _Plan:
    order: int
    input_order: int
    n_derivatives: int
    nus: tuple[int, ...]
    names: tuple[str, ...]  # unknown coefficient names, in column order
    columns: tuple[tuple[str, int], ...]  # ("a"|"b", i) per unknown
    known_a: tuple[float, ...]  # a_0..a_n (a_n = 1), zeros at unknown positions
    known_b: tuple[float, ...]
    known: tuple[tuple[str, float], ...]  # known coefficient name -> value (a_n = 1 excluded)
    dt: float
    L: int
    rule: str
    degree: int
    block: int
    block_stride: int
    guard: float
    guard_window: int
    expanding: bool
    min_intervals: int
    y_index: tuple[int, ...]  # which y kernels are needed
    u_index: tuple[int, ...]

    @property
    def window(self) -> float:
        return self.L * self.dt

    @property
    def p(self) -> int:
        return len(self.columns)

    @property
    def span(self) -> int:
        """Samples of history one estimate needs besides its own: L + (K − 1) stride."""
        return self.L + (self.block - 1) * self.block_stride

    def taps(self, L: int) -> np.ndarray:
        return _taps_for(self.order, self.nus, self.n_derivatives, L, self.rule, self.degree)


def min_window_intervals(
    integration: str = "exact", interpolation_degree: int = DEFAULT_INTERPOLATION_DEGREE
) -> int:
    """The fewest sample intervals L = T / T_s a window may span.

    The "exact" rule interpolates each window with a polynomial of ``interpolation_degree`` and
    needs that many intervals; every rule needs at least 4. Shorter windows raise SamplingError.

    Parameters
    ----------
    integration : {"exact", "simpson", "trapezoid"}
        Quadrature of the window integrals.
    interpolation_degree : int
        Degree of the local interpolant of the "exact" rule.

    Returns
    -------
    int
        The fewest sample intervals ``L``.

    Examples
    --------
    >>> min_window_intervals(), min_window_intervals("simpson")
    (7, 4)
    """
    return max(int(interpolation_degree) if integration == "exact" else 2, 4)


def _make_plan(
    model,
    dt: float,
    *,
    window,
    mu,
    integration,
    block,
    block_stride,
    extra_derivatives,
    n_equations,
    unknown,
    known,
    guard,
    guard_window,
    expanding,
    interpolation_degree,
) -> _Plan:
    """The plan of ``model`` sampled every ``dt`` under the given settings (each one checked)."""
    n = int(model.order)
    m = int(model.input_order)
    if not (0 <= m < n):
        raise InputError(
            f"the model needs 0 <= input_order < order; got order {n}, input_order {m}."
        )
    unknown, values, known_a, known_b, columns = _plan_columns(model, unknown, known)
    mu, n_eq, extra = _plan_equations(n, len(columns), mu, n_equations, extra_derivatives)
    if integration not in INTEGRATION_RULES:
        raise InputError(f"integration must be one of {INTEGRATION_RULES}; got {integration!r}.")
    block = int(block)
    block_stride = int(block_stride)
    if block < 1 or block_stride < 1:
        raise InputError(
            f"block and block_stride must be >= 1; got block={block}, block_stride={block_stride}."
        )
    L, degree, min_intervals = _plan_window(window, dt, integration, interpolation_degree)
    guard = float(guard or 0.0)
    if not (0.0 <= guard < 1.0):
        raise InputError(f"guard must lie in [0, 1) (0 disables it); got {guard!r}.")
    gw = 2 * L + 1 if guard_window is None else int(guard_window)
    if gw < 1:
        raise InputError(f"guard_window must be >= 1 window; got {guard_window!r}.")
    y_index = tuple(i for i in range(n + 1) if known_a[i] != 0.0 or ("a", i) in columns)
    u_index = tuple(i for i in range(m + 1) if known_b[i] != 0.0 or ("b", i) in columns)
    return _Plan(
        order=n,
        input_order=m,
        n_derivatives=n + extra,
        nus=tuple(range(mu, mu + n_eq)),
        names=unknown,
        columns=columns,
        known_a=tuple(known_a),
        known_b=tuple(known_b),
        known=tuple((k, values[k]) for k in model.coefficient_names if k not in unknown),
        dt=dt,
        L=L,
        rule=integration,
        degree=degree,
        block=block,
        block_stride=block_stride,
        guard=guard,
        guard_window=gw,
        expanding=bool(expanding),
        min_intervals=min_intervals,
        y_index=y_index,
        u_index=u_index,
    )


def _plan_columns(model, unknown, known):
    """The unknowns and their columns, the coefficient values, and the known ``a`` and ``b``.

    Returns (unknown names, values, known_a (a_0..a_n, a_n = 1, zeros at unknown positions),
    known_b, columns (("a" | "b" | "o", i) per unknown)).
    """
    check_known_finite(known)
    unknown, values = model.split_coefficients(unknown, known)
    known_a = [0.0 if name in unknown else values[name] for name in model.a_names] + [1.0]
    known_b = [0.0 if name in unknown else values[name] for name in model.b_names]
    columns = tuple(
        ("a", list(model.a_names).index(u))
        if u in model.a_names
        else ("b", list(model.b_names).index(u))
        for u in unknown
    )
    offset = offset_name(model)
    if offset is not None:
        # an output offset o (y_m = y + o) is one more unknown, δ' = a_0 T^n o: see
        # `_offset_column` for why it enters linearly
        columns = columns + (("o", 0),)
        unknown = tuple(unknown) + (offset,)
    return unknown, values, known_a, known_b, columns


def _plan_equations(n: int, p: int, mu, n_equations, extra_derivatives):
    """The checked ``mu``, equations per window and extra derivatives of a model of order ``n``
    with ``p`` unknowns."""
    n_eq = p if n_equations is None else int(n_equations)
    if mu is None and n + n_eq > MAX_MU:
        # the default mu = order + 1 already breaks the limit: the model, not mu, is the cause
        raise InputError(
            f"the algebraic estimator cannot handle a model of order {n} with {n_eq} "
            f"equation(s) per window: it needs powers of 1/s up to order + n_equations = "
            f"{n + n_eq}, and beyond {MAX_MU} the polynomial kernels lose every significant "
            f"digit to cancellation. Use {arg('method', repr('rls'), cli='rls')} (recursive "
            "least squares has no such limit) or a model of lower order."
        )
    mu = n + 1 if mu is None else int(mu)
    if mu < n + 1:
        raise InputError(
            f"mu must be >= order + 1 = {n + 1} (smaller powers of 1/s leave derivatives of y "
            f"in the equations); got mu = {mu}."
        )
    if mu + (p if n_equations is None else int(n_equations)) - 1 > MAX_MU:
        raise InputError(
            f"mu must be at most {MAX_MU} (with n_equations, the largest power of 1/s "
            f"mu + n_equations - 1 <= {MAX_MU}); got mu = {mu}. Beyond it the polynomial kernels "
            "lose every significant digit to cancellation and the estimate is rounding noise; "
            "use mu between order + 1 and about 10 (smoother kernels: lengthen the window or "
            "raise extra_derivatives)."
        )
    extra = int(extra_derivatives)
    if extra < 0:
        raise InputError(f"extra_derivatives must be >= 0; got {extra_derivatives!r}.")
    n_eq = p if n_equations is None else int(n_equations)
    if n_eq < p:
        raise InputError(f"n_equations must be >= the number of unknowns {p}; got {n_equations!r}.")
    return mu, n_eq, extra


def _plan_window(window, dt: float, integration: str, interpolation_degree):
    """The window's sample intervals ``L``, the interpolation degree and the fewest intervals
    allowed, checked against the quadrature rule."""
    window = check_positive(window, "window")
    L = int(round(window / dt))
    degree = int(interpolation_degree)
    if degree < 1:
        raise InputError(f"interpolation_degree must be >= 1; got {interpolation_degree!r}.")
    min_intervals = min_window_intervals(integration, degree)
    if L < min_intervals:
        raise SamplingError(
            f"window = {window:g} s is {L} sample interval(s) at dt = {dt:g} s; the kernels need "
            f"at least {min_intervals} (window >= {min_intervals * dt:g} s). Lengthen the window."
        )
    if integration == "simpson" and L % 2:
        raise InputError(
            f"integration='simpson' needs an even number of sample intervals L = window/dt; got "
            f"L = {L} (window {window:g} s, dt {dt:g} s). Change the window by one sample or use "
            "integration='exact'."
        )
    return L, degree, min_intervals


@dataclass(frozen=True)
class AlgebraicSettings:
    """Every setting of the algebraic estimator, in one place.

    `AlgebraicEstimator`, `algebraic_estimates` and `StreamingAlgebraicEstimator` take these
    settings by name; this dataclass holds their defaults and documents them once.

    Parameters
    ----------
    window : float [s]
        Window length ``T`` (rounded to ``L = round(T / dt)`` sample intervals).
    mu : int, optional
        Smallest power ``ν`` of ``1/s`` (default and minimum ``order + 1``, at most `MAX_MU`).
        Larger ``mu`` gives smoother kernels (more low-pass) at the price of a flatter, less
        sensitive system.
    integration : {"exact", "simpson", "trapezoid"}
        Quadrature of the window integrals (see `quadrature_taps`); "simpson" is the paper's eq. 21.
    block : int
        Least squares over ``block`` windows ending at ``t0, t0 − s·dt, …`` (``s = block_stride``).
    block_stride : int
        Spacing of the block's windows in samples.
    extra_derivatives : int
        ``d/ds`` applied beyond the ``order`` needed to annihilate the initial conditions
        (smoother kernels that vanish faster at both window ends). With an output offset in the
        model, one more is applied automatically (it annihilates the constant).
    n_equations : int, optional
        Equations per window (``ν = mu … mu + n_equations − 1``); default the number of unknowns,
        more gives least squares within each window.
    unknown : sequence of str, optional
        Coefficients to estimate (default ``model.unknown`` less the names in ``known``); the
        others are known.
    known : dict, optional
        Values of known coefficients overriding ``model.parameters`` (finite numbers).
    guard : float
        A window is invalid when its determinant level is below ``guard`` times the median level
        of the trailing ``guard_window`` windows (0 disables the guard).
    guard_window : int, optional
        Windows in the running median of the guard (default ``2 L + 1``).
    expanding : bool
        Before the first full window, estimate on the growing window ``[0, t0]`` (from
        ``max(interpolation_degree, 4)`` samples on). Each length has its own taps: a start-up
        cost of order ``L²``, meant for windows of up to a few hundred samples.
    interpolation_degree : int
        Degree of the local interpolant of the "exact" rule.
    final_fraction : float in (0, 1]
        The final estimate uses the valid full windows in the trailing ``final_fraction`` of the
        record (1: the whole record).
    final : {"lstsq", "median", "bias-compensated"}
        "lstsq" (default): least squares on all their equations pooled, after dropping windows
        whose own estimate lies beyond 5 robust standard deviations of the median (6-14x more
        accurate than the median on a stationary noisy record, and half PySINDy's ω0 error or
        better at 25/50/80 dB, see docs/algebraic.md); "median": the median of those windows'
        estimates (robust to a parameter change inside the record); "bias-compensated": pooled
        least squares over *every* full window (no guard, no screen: selecting windows by their
        noisy level or estimate biases θ2 by ~1 % at 30 dB) with the errors-in-variables bias of
        the output noise removed (`_bias_compensated`); its standard errors reach nominal
        coverage at 30 and 60 dB (benchmarks/bench_coverage.py). The default's standard errors
        are withheld (``stderr`` None, ``stderr_reason`` with the numbers) where its estimate
        lies more than `MAX_SHIFT_TO_STDERR` of them from the bias-compensated one: at 30 dB on
        the paper's MSD (θ2 biased by ~6 of them) always, at 60 dB in a minority of records.
        The default stays "lstsq": on stationary records "bias-compensated" is more accurate
        (ω0 RMS error over 5 seeds at 25 dB: 8e-4 against 4.5e-3 at Z = 10), but every window
        enters it, and on the paper's disturbed record (ω2 = 500 ω0, aliased; 80 dB, Z = 10)
        its ω0 error is 3.0 % against the screened default's 0.69 %.

    Examples
    --------
    >>> s = AlgebraicSettings(window=0.1)
    >>> s.window, s.final, s.replace(final="median").final
    (0.1, 'lstsq', 'median')
    """

    window: float = 0.05
    mu: int | None = None
    integration: str = "exact"
    block: int = 1
    block_stride: int = 1
    extra_derivatives: int = 0
    n_equations: int | None = None
    unknown: Sequence[str] | None = None
    known: Mapping[str, float] | None = None
    guard: float = DEFAULT_GUARD
    guard_window: int | None = None
    expanding: bool = False
    interpolation_degree: int = DEFAULT_INTERPOLATION_DEGREE
    final_fraction: float = 1.0
    final: str = "lstsq"

    #: Settings that only shape the final estimate (not the per-window estimates).
    FINAL_ONLY = ("final_fraction", "final")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The setting names, in order."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def from_kwargs(cls, where: str, allowed: Sequence[str] | None = None, **kwargs):
        """Build from keywords, refusing unknown names with the list of allowed ones."""
        allowed = cls.names() if allowed is None else tuple(allowed)
        bad = sorted(set(kwargs) - set(allowed))
        if bad:
            raise InputError(f"unknown setting(s) {bad} for {where}; allowed: {sorted(allowed)}.")
        return cls(**kwargs)

    def replace(self, **changes) -> AlgebraicSettings:
        """A copy with some settings changed."""
        return dataclasses.replace(self, **changes)

    def plan_settings(self) -> dict[str, Any]:
        """The settings that shape the per-window systems (all but `FINAL_ONLY`)."""
        return {k: getattr(self, k) for k in self.names() if k not in self.FINAL_ONLY}

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready name -> value."""
        out = {k: getattr(self, k) for k in self.names()}
        out["unknown"] = None if self.unknown is None else list(self.unknown)
        out["known"] = None if self.known is None else dict(self.known)
        return out


def _settings_plan(model, dt, settings: AlgebraicSettings):
    return _make_plan(as_linear_ode_model(model), dt, **settings.plan_settings())
