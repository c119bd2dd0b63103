"""Variance of the recursive estimator of θ2 under a sinusoidal input, and the best input frequency.

Oueslati et al. (2011), section 3.B–3.D, eqs. 5–13, re-derived.

Setting (the paper's simplification): the damping is neglected, the only unknown is θ2 = ω0², the
regressor is the noise-free response ``x_i = x(t_i)``, ``t_i = i T_s``, to ``u = A1 sin(ω1 t)`` from
rest, and the rows ``Y_i = θ2 x_i + ρ_i`` carry white noise of variance σ². The recursion (eq. 3)
with forgetting λ gives the exponentially weighted LS estimate over rows ``i = m+1 … k``::

    θ̂2 = Σ λ^{k−i} x_i Y_i / Σ λ^{k−i} x_i²
    Var θ̂2 = σ² Σ λ^{2(k−i)} x_i² / (Σ λ^{k−i} x_i²)² = (σ² / A1²) K(Z, λ, ω0, T_s, m, k)   (eq. 11)

with ``x(t) = A1 g(t)``, ``Z = ω1 / ω0``, ``a = ω0 t`` and (eq. 8, re-derived)::

    g(t) = (Z sin a − sin Z a) / (ω0² (Z² − 1))                                               (8)
         = [sin a − a cos((1+Z) a / 2) · sinc((Z−1) a / 2)] / (ω0² (Z + 1))         (stable form)

    K = Σ λ^{2(k−i)} g_i² / (Σ λ^{k−i} g_i²)²
      = (ω0² (Z² − 1))² Σ λ^{2(k−i)} h_i² / (Σ λ^{k−i} h_i²)²,   h = Z sin a − sin Z a       (12)

The stable form uses ``sin a − sin Za = −2 cos((1+Z)a/2) sin((Z−1)a/2)`` and
``sinc(x) = sin x / x``; it has no 0/0 at Z = 1, where it is the resonant solution
``(sin a − a cos a) / (2 ω0²)``.

Errata found in the paper (checked in ``tests/test_input_design.py``):

* eq. 5: ``α(i) = k − max{i − m, k}`` is 0 for every ``i ≤ k`` (no forgetting at all); the
  exponent the recursion (3) produces is ``α(i) = k − i``.
* eq. 8 is 0/0 at Z = 1 (resonance); its limit is the resonant solution above.
* eq. 12 prints ``Z sin(ω0 t) − ω0 sin(Z ω0 t)``: the second ω0 is spurious (eq. 8 with
  ω1 = Z ω0 gives ``Z sin a − sin Za``; eq. 13 has it right). With the spurious factor (ω0 ≈ 11.5
  rad/s) the function is a different one and disagrees with Monte Carlo.
* eq. 13 (λ = 1) shows ``Σ h²`` once in the denominator: that is *consistent* with eq. 12, since
  at λ = 1 the numerator sum equals one of the two denominator sums.

What the formula says (T_s = 1 ms, ω0 = √(400/3) rad/s, m = 3): for the paper's own horizon
k = 100 (0.1 s, under a fifth of a period) K decreases monotonically over Z ∈ [0.01, 2], so the
optimum is the *upper end* Z = 2 for every λ (near the start ``g ≈ Z a³ / (6 ω0²)`` grows with Z),
not Z = 1; λ = 1 gives the smallest K. The optimum approaches Z = 1 only for horizons of a few
natural periods (k ≳ 2000 samples); see `optimal_ratio` and docs/recursive.md for the numbers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import optimize

from .._validate import as_1d, check_int, check_positive
from ..errors import InputError, arg
from ..estimators.results import ResultMixin
from ..models.linear_ode import MSD_NATURAL_FREQUENCY

__all__ = [
    "PAPER_NATURAL_FREQUENCY",
    "resonant_response",
    "variance_factor",
    "variance_factor_printed",
    "optimal_ratio",
    "design_input",
    "InputDesignResult",
]

#: ω0 of the paper's system, √(k/m) = √(400 N/m / 3 kg) [rad/s].
PAPER_NATURAL_FREQUENCY = MSD_NATURAL_FREQUENCY
#: Largest number of (ratio × row) terms evaluated at once (memory bound of the vectorised sums).
_CHUNK_TERMS = 4_000_000


def resonant_response(ratio, t, natural_frequency: float) -> np.ndarray:
    """``g(t) = x(t) / A1`` of ẍ + ω0² x = A1 sin(Z ω0 t), x(0) = ẋ(0) = 0 (eq. 8) [s²].

    Parameters
    ----------
    ratio : array_like
        Z = ω1 / ω0 ≥ 0 (broadcast against ``t``).
    t : array_like [s]
    natural_frequency : float [rad/s]
        ω0.

    Returns
    -------
    ndarray
        The stable form ``[sin a − a cos((1+Z)a/2) sinc((Z−1)a/2)] / (ω0² (Z+1))``, ``a = ω0 t``,
        exact for all Z including the resonance Z = 1.

    Examples
    --------
    At resonance the response grows like t (the 0/0 of eq. 8 resolved):

    >>> w0 = 2.0; t = np.array([1.0, 3.0])
    >>> bool(np.allclose(resonant_response(1.0, t, w0),
    ...                  (np.sin(w0 * t) - w0 * t * np.cos(w0 * t)) / (2 * w0**2)))
    True
    """
    Z = np.asarray(ratio, dtype=float)
    a = natural_frequency * np.asarray(t, dtype=float)
    # np.sinc(y) = sin(πy)/(πy), so sin(x)/x = np.sinc(x/π) with x = (Z−1)a/2
    shaped = np.sin(a) - a * np.cos(0.5 * (1.0 + Z) * a) * np.sinc(0.5 * (Z - 1.0) * a / np.pi)
    return shaped / (natural_frequency**2 * (Z + 1.0))


def _check_design_args(natural_frequency, sample_period, init_samples, samples):
    w0 = check_positive(natural_frequency, "natural_frequency")
    ts = check_positive(sample_period, "sample_period")
    m = check_int(init_samples, "init_samples", minimum=0)
    k = check_int(samples, "samples", minimum=1)
    if k <= m:
        raise InputError(
            f"need {arg('init_samples')} < {arg('samples')} (rows m+1..k); got "
            f"{arg('init_samples', repr(init_samples), cli=str(init_samples))}, "
            f"{arg('samples', repr(samples), cli=str(samples))}. Raise {arg('samples')} or lower "
            f"{arg('init_samples')}."
        )
    return w0, ts, m, k


def _check_forgetting(forgetting) -> np.ndarray:
    lam = np.asarray(forgetting, dtype=float)
    bad = ~((lam > 0) & (lam <= 1))
    if np.any(bad):
        raise InputError(
            f"forgetting must lie in (0, 1]; got {lam[bad].ravel().tolist()} among "
            f"{lam.ravel().tolist()}."
        )
    return lam


def variance_factor(
    ratio,
    forgetting=1.0,
    *,
    natural_frequency: float = PAPER_NATURAL_FREQUENCY,
    sample_period: float = 1e-3,
    init_samples: int = 3,
    samples: int = 100,
) -> np.ndarray:
    """K(Z, λ, ω0, T_s, m, k) of eq. 12 (re-derived): Var θ̂2 = σ² / A1² · K.

    Parameters
    ----------
    ratio : array_like, shape (nz,) or scalar
        Z = ω1 / ω0 ≥ 0.
    forgetting : array_like, shape (nl,) or scalar
        λ in (0, 1].
    natural_frequency : float [rad/s]
        ω0 (default the paper's √(400/3)).
    sample_period : float [s]
        T_s.
    init_samples : int
        m: rows start at i = m + 1.
    samples : int
        k: the estimate after k samples.

    Returns
    -------
    ndarray, shape forgetting.shape + ratio.shape  [s⁻⁴]
        ``Σ λ^{2(k−i)} g_i² / (Σ λ^{k−i} g_i²)²`` with g from `resonant_response`.

    Examples
    --------
    At λ = 1, K = 1 / Σ g_i²:

    >>> t = np.arange(4, 101) * 1e-3
    >>> g = resonant_response(1.5, t, 10.0)
    >>> bool(np.isclose(variance_factor(1.5, natural_frequency=10.0), 1 / np.sum(g**2)))
    True
    """
    w0, ts, m, k = _check_design_args(natural_frequency, sample_period, init_samples, samples)
    Z = np.asarray(ratio, dtype=float)
    if np.any(~np.isfinite(Z)) or np.any(Z < 0):
        raise InputError(f"ratio must be finite and >= 0; got {Z.ravel()[:5].tolist()}...")
    lam = _check_forgetting(forgetting)
    from .._resources import check_memory

    # peak: λ^{k−i} and its square (2 n_λ rows), t, i, age (3 rows), one chunk of g² (≥ rows)
    check_memory(
        8.0 * ((k - m) * (2 * lam.size + 3) + 3 * max(_CHUNK_TERMS, k - m)),
        what=f"variance_factor with samples={k}",
        fix="lower samples",
    )
    i = np.arange(m + 1, k + 1)
    t = i * ts
    age = (k - i).astype(float)  # α(i) = k − i (eq. 5 corrected)
    with np.errstate(under="ignore"):
        w = lam.reshape(-1, 1) ** age  # (nl, rows) λ^{k−i}
    z_flat = Z.ravel()
    out = np.empty((w.shape[0], z_flat.size))
    step = max(1, _CHUNK_TERMS // t.size)
    for start in range(0, z_flat.size, step):  # chunks bound memory; each chunk is vectorised
        g2 = resonant_response(z_flat[start : start + step, None], t[None, :], w0) ** 2
        num = (w**2) @ g2.T  # Σ λ^{2(k−i)} g²
        den = w @ g2.T  # Σ λ^{k−i} g²
        out[:, start : start + step] = num / den**2
    return out.reshape(lam.shape + Z.shape)


def variance_factor_printed(
    ratio,
    *,
    natural_frequency: float = PAPER_NATURAL_FREQUENCY,
    sample_period: float = 1e-3,
    init_samples: int = 3,
    samples: int = 100,
) -> np.ndarray:
    """Eq. 12 *as printed* at λ = 1 (spurious ω0: ``Z sin ω0t − ω0 sin Zω0t``), for comparison.

    ``K_printed = (ω0² (Z² − 1))² / Σ_{i=m+1}^{k} h_i²`` with
    ``h_i = Z sin ω0 t_i − ω0 sin Z ω0 t_i``, ``t_i = i T_s``. The derivation gives
    ``Z sin ω0t − sin Zω0t`` (see `variance_factor`): the printed ω0 makes the formula
    dimensionally inconsistent, and it agrees with the re-derived K only when ω0 = 1 rad/s.

    Parameters
    ----------
    ratio : array_like, shape (nz,) or scalar
        Z = ω1 / ω0 (dimensionless), Z ≠ 1 (the printed formula is 0/0 there).
    natural_frequency : float [rad/s]
        ω0 (default the paper's √(400/3)).
    sample_period : float [s]
        T_s.
    init_samples : int
        m: rows start at i = m + 1.
    samples : int
        k: the estimate after k samples.

    Returns
    -------
    ndarray, shape ratio.shape
        K as printed; in s⁻⁴ only where ω0 = 1 rad/s (elsewhere it has no consistent unit).

    Examples
    --------
    With ω0 = 1 rad/s the spurious factor is 1 and the printed formula equals the derived one:

    >>> bool(np.isclose(variance_factor_printed(1.5, natural_frequency=1.0),
    ...                 variance_factor(1.5, natural_frequency=1.0), rtol=1e-12))
    True
    """
    w0, ts, m, k = _check_design_args(natural_frequency, sample_period, init_samples, samples)
    Z = np.asarray(ratio, dtype=float)[..., None]
    t = np.arange(m + 1, k + 1) * ts
    h = Z * np.sin(w0 * t) - w0 * np.sin(Z * w0 * t)
    return (w0**2 * (Z[..., 0] ** 2 - 1)) ** 2 / np.sum(h**2, axis=-1)


def optimal_ratio(
    forgetting=1.0,
    *,
    ratio_range: tuple[float, float] = (0.01, 2.0),
    natural_frequency: float = PAPER_NATURAL_FREQUENCY,
    sample_period: float = 1e-3,
    init_samples: int = 3,
    samples: int = 100,
    n_grid: int | None = None,
):
    """The ratio Z in ``ratio_range`` that minimises K, for each λ.

    Parameters
    ----------
    forgetting : array_like or float
        λ in (0, 1] (scalar or any shape).
    ratio_range : (float, float)
        (LO, HI), 0 ≤ LO < HI: the range of Z = ω1 / ω0 (dimensionless) searched.
    natural_frequency : float [rad/s]
        ω0 (default the paper's √(400/3)).
    sample_period : float [s]
        T_s.
    init_samples : int
        m: rows start at i = m + 1.
    samples : int
        k: the horizon of the estimate, in samples.
    n_grid : int, optional
        Points of the search grid (default below).

    A dense grid locates the global minimum; a bounded scalar search
    (``scipy.optimize.minimize_scalar``, method "bounded", xatol 1e-10) between its grid neighbours
    refines it. K(Z) wiggles on the scale ``ΔZ ≈ 2π / (ω0 k T_s)`` (the beat between ω1 and ω0
    over the horizon), so the default grid has 16 points per wiggle, at least 400:
    ``n_grid = max(400, ceil(16 (HI − LO) ω0 k T_s / 2π))``.

    Returns
    -------
    ratio : ndarray, shape forgetting.shape
        The optimal Z (dimensionless).
    K : ndarray, shape forgetting.shape [s⁻⁴]
        The variance factor there (`variance_factor`).
    at_boundary : ndarray of bool, shape forgetting.shape
        Whether the optimum sits on an end of the range (then the true minimum may lie outside
        it: widen ``ratio_range``).

    Examples
    --------
    Over a few natural periods the optimum is the resonance:

    >>> z, _, edge = optimal_ratio(1.0, natural_frequency=10.0, samples=20000)
    >>> round(float(z), 3), bool(edge)
    (1.0, False)
    """
    lo, hi = _check_range(ratio_range)
    lam = _check_forgetting(forgetting)
    if n_grid is None:
        beats = (hi - lo) * natural_frequency * samples * sample_period / (2 * np.pi)
        n_grid = max(400, math.ceil(16 * beats))
    grid = np.linspace(lo, hi, int(n_grid))
    kw = dict(
        natural_frequency=natural_frequency,
        sample_period=sample_period,
        init_samples=init_samples,
        samples=samples,
    )
    K = variance_factor(grid, lam.ravel(), **kw)  # (nl, n_grid)
    best = np.argmin(K, axis=1)
    z_opt = np.empty(lam.size)
    k_opt = np.empty(lam.size)
    edge = np.zeros(lam.size, dtype=bool)
    for j, (lam_j, b) in enumerate(zip(lam.ravel(), best, strict=True)):  # one search per λ
        a_, b_ = grid[max(b - 1, 0)], grid[min(b + 1, grid.size - 1)]
        res = optimize.minimize_scalar(
            lambda z, lam_j=lam_j: float(np.log(variance_factor(z, lam_j, **kw))),
            bounds=(a_, b_),
            method="bounded",
            options={"xatol": 1e-10},
        )
        z_opt[j], k_opt[j] = (
            (res.x, math.exp(res.fun)) if math.exp(res.fun) <= K[j, b] else (grid[b], K[j, b])
        )
        edge[j] = bool(
            np.isclose(z_opt[j], lo, rtol=0, atol=1e-6 * (hi - lo))
            or np.isclose(z_opt[j], hi, rtol=0, atol=1e-6 * (hi - lo))
        )
    return z_opt.reshape(lam.shape), k_opt.reshape(lam.shape), edge.reshape(lam.shape)


#: Most terms resonant_response(Z, t_i) one design_input call may evaluate (about a minute).
MAX_TERMS = 2_000_000_000


def _search_grid(lo, hi, natural_frequency, samples, sample_period) -> int:
    """Points of the dense grid `optimal_ratio` searches (16 per beat period of the record)."""
    beats = (hi - lo) * natural_frequency * samples * sample_period / (2 * np.pi)
    return max(400, math.ceil(16 * beats))


def _check_request_size(n_lam, n_ratios, ratio_range, w0, ts, samples, horizons) -> None:
    """Refuse a design whose arrays or work would not fit, before allocating anything.

    Peak memory of `variance_factor` for k rows and n_λ factors: the weights λ^{k−i} and their
    squares (2 n_λ k doubles), t, i, age (3 k) and one chunk of g² (`_CHUNK_TERMS` doubles, at
    least k). Work: n_ratios·k terms per curve plus the search grid × k per optimum.
    """
    from .._resources import check_memory, format_bytes

    lo, hi = ratio_range
    rows = max([samples, *horizons])
    nbytes = 8.0 * (rows * (2 * n_lam + 3) + 3 * max(_CHUNK_TERMS, rows))
    check_memory(
        nbytes,
        what=f"the input design with {rows} samples",
        fix="lower samples (and horizons; by default they go up to 30 × samples)",
    )
    terms = 0.0
    for h, n in [(samples, n_lam)] + [(h, 1) for h in horizons]:
        terms += h * n * (n_ratios + _search_grid(lo, hi, w0, h, ts))
    if terms > MAX_TERMS:
        raise InputError(
            f"the input design with {arg('samples', str(samples))} and "
            f"{arg('horizons', str(list(horizons)), cli=','.join(str(h) for h in horizons))} "
            f"evaluates about {terms:.3g} terms (limit {MAX_TERMS:.3g}, about a minute; memory "
            f"{format_bytes(nbytes)}): the search grid grows with the record's length, so the "
            f"work grows with its square. Lower {arg('samples')} (or give shorter "
            f"{arg('horizons')})."
        )


def _check_range(ratio_range) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in ratio_range)
    except (TypeError, ValueError):
        raise InputError(
            f"ratio_range must be two numbers (LO, HI); got {ratio_range!r}."
        ) from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
        raise InputError(
            f"ratio_range must satisfy 0 <= LO < HI (finite); got ({lo:g}, {hi:g}). Swap or "
            "widen it."
        )
    return lo, hi


@dataclass(frozen=True, eq=False)
class InputDesignResult(ResultMixin):
    """Variance factor curves and optimal frequency ratios (paper Figs. 2 and 3).

    Attributes
    ----------
    ratio : ndarray (nz,) — the Z grid.
    forgetting : tuple of float (nl,) — λ values.
    variance_factor : ndarray (nl, nz) — K(Z, λ) [s⁻⁴].
    optimal_ratio : tuple (nl,) — Z minimising K in the range, per λ.
    optimal_variance_factor : tuple (nl,) — K there.
    at_boundary : tuple of bool (nl,) — the optimum is an end of the range.
    horizons : tuple of int — k values of the horizon study (λ = 1, Fig. 3).
    horizon_variance_factor : ndarray (nh, nz) — K(Z, 1, k) for each horizon.
    horizon_optimal_ratio : tuple (nh,) — optimal Z per horizon (same range).
    natural_frequency [rad/s], sample_period [s], init_samples (m), samples (k).
    """

    ratio: np.ndarray
    forgetting: tuple[float, ...]
    variance_factor: np.ndarray
    optimal_ratio: tuple[float, ...]
    optimal_variance_factor: tuple[float, ...]
    at_boundary: tuple[bool, ...]
    horizons: tuple[int, ...]
    horizon_variance_factor: np.ndarray
    horizon_optimal_ratio: tuple[float, ...]
    natural_frequency: float
    sample_period: float
    init_samples: int
    samples: int
    success: bool = True
    message: str = ""
    metadata: dict[str, Any] = field(default_factory=dict)

    _history_fields = ("ratio", "variance_factor", "horizon_variance_factor")

    @property
    def parameters(self) -> dict[str, float]:
        """Optimal ratio per λ, keyed ``"optimal_ratio(lambda=0.95)"``."""
        return {
            f"optimal_ratio(lambda={lam:g})": z
            for lam, z in zip(self.forgetting, self.optimal_ratio, strict=True)
        }

    def optimal_ratio_by_forgetting(self) -> dict[str, float]:
        """``{"0.95": Z*, ...}`` (JSON keys are strings)."""
        return {f"{lam:g}": z for lam, z in zip(self.forgetting, self.optimal_ratio, strict=True)}

    def plot(self, ax=None):
        """log10 K against Z for each λ and each horizon; see `physid.report.input_design`."""
        from ..report.input_design import plot_input_design

        return plot_input_design(self, ax=ax)


def design_input(
    *,
    forgetting: Sequence[float] = (0.95, 0.98, 0.99, 1.0),
    ratio_range: tuple[float, float] = (0.01, 2.0),
    n_ratios: int = 400,
    natural_frequency: float = PAPER_NATURAL_FREQUENCY,
    sample_period: float = 1e-3,
    init_samples: int = 3,
    samples: int = 100,
    horizons: Sequence[int] | None = None,
) -> InputDesignResult:
    """Curves of K(Z) for several λ (Fig. 2) and horizons k (Fig. 3), and the optimal ratios.

    Parameters
    ----------
    forgetting : sequence of float in (0, 1]
    ratio_range : (float, float)
        Z range of the curves and of the search (paper: [0.01, 2]).
    n_ratios : int
        Points of the plotted curves (the search uses its own dense grid).
    natural_frequency : float [rad/s], default √(400/3) (paper)
    sample_period : float [s], default 1 ms
    init_samples, samples : int
        m and k (paper: 3 and 100).
    horizons : sequence of int, optional
        k values for the λ = 1 study; default ``samples × (1, 3, 10, 30)``.

    Returns
    -------
    InputDesignResult
    """
    lam = _check_forgetting(as_1d(forgetting, "forgetting"))
    lo, hi = _check_range(ratio_range)
    n_ratios = int(n_ratios)
    if n_ratios < 3:
        raise InputError(f"n_ratios must be >= 3; got {n_ratios}.")
    w0, ts, m, k = _check_design_args(natural_frequency, sample_period, init_samples, samples)
    if horizons is None:
        horizons = tuple(int(k * f) for f in (1, 3, 10, 30))
    horizons = tuple(int(h) for h in horizons)
    if any(h <= m for h in horizons):
        raise InputError(f"every horizon must exceed init_samples = {m}; got {list(horizons)}.")
    _check_request_size(lam.size, n_ratios, (lo, hi), w0, ts, k, horizons)
    kw = dict(natural_frequency=w0, sample_period=ts, init_samples=m)
    Z = np.linspace(lo, hi, n_ratios)
    K = variance_factor(Z, lam, samples=k, **kw)
    z_opt, k_opt, edge = optimal_ratio(lam, ratio_range=(lo, hi), samples=k, **kw)
    H = np.stack([variance_factor(Z, 1.0, samples=h, **kw) for h in horizons])
    hz = [float(optimal_ratio(1.0, ratio_range=(lo, hi), samples=h, **kw)[0]) for h in horizons]
    notes = []
    if edge.any():
        notes.append(
            "the optimum lies on an end of the ratio range for λ = "
            + ", ".join(f"{v:g}" for v in lam[edge])
            + ": K keeps decreasing beyond it; widen the ratio range to locate the minimum."
        )
    return InputDesignResult(
        ratio=Z,
        forgetting=tuple(float(v) for v in lam),
        variance_factor=K,
        optimal_ratio=tuple(float(v) for v in z_opt),
        optimal_variance_factor=tuple(float(v) for v in k_opt),
        at_boundary=tuple(bool(v) for v in edge),
        horizons=horizons,
        horizon_variance_factor=H,
        horizon_optimal_ratio=tuple(hz),
        natural_frequency=w0,
        sample_period=ts,
        init_samples=m,
        samples=k,
        success=True,
        message=" ".join(notes),
    )
