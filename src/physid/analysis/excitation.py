"""Optimal excitation for rigid-body identification: finite Fourier series (Swevers et al.).

Reference: Swevers, Ganseman, Tükel, De Schutter & Van Brussel, "Optimal robot excitation and
identification", IEEE Trans. Robotics and Automation 13(5), 1997; Gautier & Khalil, "Exciting
trajectories for the identification of base inertial parameters of robots", IJRR 11(4), 1992.

Each joint follows a finite Fourier series of period T = 2π/ω_f with H harmonics::

    q_j(t) = q_start,j + φ_j(t) − φ_j(0),
    φ_j(t) = Σ_{l=1}^{H}  a_jl/(l ω_f) sin(l ω_f t) − b_jl/(l ω_f) cos(l ω_f t)

so that q̇_j = Σ_l (a_jl cos + b_jl sin), q̈_j = ω_f Σ_l l (b_jl cos − a_jl sin). Starting
(and, by periodicity, ending) at rest: q̇(0) = Σ_l a_jl = 0 and q̈(0) = ω_f Σ_l l b_jl = 0; we
eliminate a_j1 and b_j1 with these two equations, leaving 2(H − 1) free coefficients per joint.
The design variables are these coefficients and, with ``q_start="optimise"``, the rest position.

**Criterion.** The base regressor W_b (the columns of the standard regressor that
`physid.estimators.idim.base_regressor_info` keeps), evaluated on a grid over one period and
stacked over samples and joints (n_samples·n_joints rows, one column per base parameter), with
every column scaled to unit Euclidean norm: ``cond(W_b D)``, ``D = diag(1/‖w_k‖)``. Unscaled,
the number is dominated by the parameters' units (a Coulomb column in N·m against an inertia
column in kg·m²·rad/s²) and says more about the units than about the excitation; the scaled
number is what `physid.estimators.idim.condition_number` reports and what IDIM warns on. The
unscaled number is reported too (`ExcitationDesign.unscaled`), for comparison with papers that
use it.

**Constraints.** q, q̇ and q̈ are linear in the design variables, so the limits (position range,
|q̇| ≤ v_max, |q̈| ≤ a_max, each times `MARGIN`) are linear inequalities at the samples of the
search grid. The design is then checked on a grid 20× finer and any joint that overshoots between
the samples is shrunk about q_start, so every limit holds on the fine grid.

**Search.** SLSQP (scipy) with these linear constraints minimises a smooth upper bound of
log cond: ``½ (softmax_p(log λ) − softmin_p(log λ))`` over the eigenvalues λ of the scaled
information matrix, p = `SOFT_P` (the true log cond is not differentiable where the extreme
eigenvalues cluster, which is where its optimum lies). The gradient is a forward difference
evaluated in one batched call of the regressor. Several starts (the best random trajectories),
within a wall-time budget; the best by the true condition number is kept.

**Baselines** (both reported, on the same verification grid as the design, same H, T, limits and
rest position): *random, scaled to the limits*: coefficients N(0, 1), each joint then scaled to
`MARGIN` times its tightest limit (this scaling is itself a strong improvement over an arbitrary
random draw); *random within the limits*: the same trajectories with each joint's amplitude a
uniform random fraction U(0, 1) of that feasible maximum (a random trajectory that merely
satisfies the limits).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, arg
from .excitation_search import BATCH_BYTES as BATCH_BYTES
from .excitation_search import FD_STEP as FD_STEP
from .excitation_search import MARGIN as MARGIN
from .excitation_search import SOFT_P as SOFT_P
from .excitation_search import (
    _criteria,
    _scaled,
    _Search,
    _search_from_starts,
    _unscaled_cond,
    fourier_trajectory,
)

__all__ = [
    "ExcitationDesign",
    "design_excitation",
    "fourier_trajectory",
    "excitation_limits",
    "random_excitation",
]

#: Acceleration limit [rad/s²] used when neither the model nor the caller gives one, as a
#: multiple of the velocity limit [rad/s] (a URDF has no acceleration limits).
ACCELERATION_PER_VELOCITY = 5.0


@dataclass(frozen=True, eq=False)
class ExcitationDesign:
    """A designed excitation and how good it is, against random trajectories.

    All condition numbers are of the base regressor with its columns scaled to unit norm,
    evaluated on the same verification grid (``n_check`` samples per period), unless named
    ``unscaled``.

    Attributes
    ----------
    period : float [s]
    harmonics : int
    coefficients : ndarray, shape (n_joints, 2, harmonics)
        ``a_jl`` (``[:, 0]``) and ``b_jl`` (``[:, 1]``) [rad/s].
    q_start : ndarray, shape (n_joints,) [rad]
        Rest position at both ends.
    condition_number : float
        Column-scaled condition number of the designed base regressor.
    log_det : float
        log det of the column-scaled information matrix.
    random_condition_numbers : ndarray, shape (n_random,)
        Random Fourier trajectories, each joint scaled to touch its tightest limit
        (baseline "random, scaled to the limits").
    random_within_condition_numbers : ndarray, shape (n_random,)
        The same trajectories with each joint's amplitude a uniform random fraction of that
        maximum (baseline "random within the limits").
    criterion : str
    limits : dict
        ``position`` (n, 2), ``velocity`` (n,), ``acceleration`` (n,) used.
    peak : dict
        Largest |q − q_start|, |q̇|, |q̈| reached on the fine check grid, per joint, and
        ``q_min``/``q_max`` [rad].
    seconds : float
        Wall time of the design (baselines included).
    nfev : int
        Trajectories evaluated by the search (each gradient counts n_variables + 1).
    starts : tuple of float
        Condition number reached from each start (on the search grid).
    unscaled : dict
        ``designed`` and ``random_median`` (scaled to the limits) condition numbers of the
        unscaled base regressor (unit-dependent; for comparison only).
    n_check : int
        Samples per period of the verification grid.
    """

    period: float
    harmonics: int
    coefficients: np.ndarray = field(repr=False)
    q_start: np.ndarray
    condition_number: float
    log_det: float
    random_condition_numbers: np.ndarray = field(repr=False)
    criterion: str
    limits: dict = field(repr=False)
    peak: dict = field(repr=False)
    seconds: float
    nfev: int
    random_within_condition_numbers: np.ndarray = field(repr=False, default=None)
    starts: tuple = ()
    unscaled: dict = field(repr=False, default_factory=dict)
    n_check: int = 0

    @property
    def random_median(self) -> float:
        """Median condition number of the random trajectories scaled to the limits."""
        return float(np.median(self.random_condition_numbers))

    @property
    def random_within_median(self) -> float:
        """Median condition number of the random trajectories within the limits."""
        if self.random_within_condition_numbers is None:
            return float("nan")
        return float(np.median(self.random_within_condition_numbers))

    @property
    def improvement(self) -> float:
        """``random_median / condition_number`` (against random trajectories scaled to the
        limits: the claim physid makes)."""
        return self.random_median / self.condition_number

    @property
    def improvement_within(self) -> float:
        """``random_within_median / condition_number`` (against random trajectories that merely
        satisfy the limits)."""
        return self.random_within_median / self.condition_number

    def trajectory(self, t):
        """q, q̇, q̈ at times t [s], each (n_samples, n_joints).

        Parameters
        ----------
        t : array_like, shape (n,) [s]

        Returns
        -------
        q, qd, qdd : ndarray, each (n, n_joints) [rad], [rad/s], [rad/s²]
        """
        return fourier_trajectory(self.coefficients, t, self.period, self.q_start)

    def to_recording(self, *, dt: float = 1e-3, periods: int = 1):
        """The trajectory as a recording of references ``r1..rn`` [rad] (and ``rd1..rdn``).

        Parameters
        ----------
        dt : float [s]
            Sample period.
        periods : int
            Number of periods.

        Returns
        -------
        Recording
            ``t`` from 0 to ``periods · period``, ``r1..rn`` [rad], ``rd1..rdn`` [rad/s],
            ``rdd1..rddn`` [rad/s²]; metadata with the design.
        """
        from ..signals.recording import Recording

        n = int(round(periods * self.period / dt))
        t = np.arange(n + 1) * dt
        q, qd, qdd = self.trajectory(t)
        nj = q.shape[1]
        names = (
            [f"r{j + 1}" for j in range(nj)]
            + [f"rd{j + 1}" for j in range(nj)]
            + [f"rdd{j + 1}" for j in range(nj)]
        )
        units = ["rad"] * nj + ["rad/s"] * nj + ["rad/s^2"] * nj
        meta = {
            "generator": "physid.analysis.design_excitation",
            "period": self.period,
            "harmonics": self.harmonics,
            "criterion": self.criterion,
            "condition_number": self.condition_number,
            "random_median_condition_number": self.random_median,
            "random_within_median_condition_number": self.random_within_median,
            "q_start": self.q_start.tolist(),
            "coefficients": self.coefficients.tolist(),
        }
        return Recording(t, np.column_stack([q, qd, qdd]), tuple(names), tuple(units), meta)

    def summary(self) -> str:
        """The achieved condition number against both random baselines."""
        n = self.random_condition_numbers.size
        return (
            f"Fourier excitation: {self.harmonics} harmonics, period {self.period:g} s; "
            f"condition number of the column-scaled base regressor {self.condition_number:.4g} "
            f"vs median {self.random_median:.4g} of {n} random trajectories scaled to the same "
            f"limits ({self.improvement:.3g}× lower) and median {self.random_within_median:.4g} "
            f"of the same trajectories at random amplitudes within the limits "
            f"({self.improvement_within:.3g}× lower); {len(self.starts)} starts, "
            f"{self.nfev} trajectory evaluations in {self.seconds:.3g} s."
        )


def excitation_limits(model, *, position=None, velocity=None, acceleration=None) -> dict:
    """Limits for the design: given ones, else the model's (``model.limits``), else defaults.

    Parameters
    ----------
    model : ChainModel
    position : array_like, shape (n, 2) [rad], optional
    velocity, acceleration : array_like, shape (n,) or scalar [rad/s], [rad/s²], optional

    Returns
    -------
    dict
        ``position`` (n, 2), ``velocity`` (n,), ``acceleration`` (n,); unknown position limits
        become ±π, unknown velocity limits 1 rad/s, unknown acceleration limits
        ``ACCELERATION_PER_VELOCITY × velocity``.

    Raises
    ------
    InputError
        Limits that cannot be met: lower ≥ upper, a non-positive velocity or acceleration limit,
        a shape that does not match the joints.
    """
    n = int(model.n_joints)
    lim = dict(getattr(model, "limits", None) or {})

    def pick(value, key, shape, default):
        v = value if value is not None else lim.get(key)
        if v is None:
            return np.full(shape, np.nan)
        arr = np.asarray(v, dtype=float)
        if arr.ndim == 0 or arr.size == 1 and shape != (n, 2):
            arr = np.full(shape, float(arr.ravel()[0]))
        if arr.shape != shape:
            raise InputError(
                f"{arg(key)} must have shape {shape} (one entry per joint); got shape {arr.shape}."
            )
        return arr

    pos = pick(position, "position", (n, 2), None)
    vel = pick(velocity, "velocity", (n,), None)
    acc = pick(acceleration, "acceleration", (n,), None)
    pos = np.where(np.isnan(pos), np.array([-np.pi, np.pi])[None, :], pos)
    vel = np.where(np.isnan(vel), 1.0, vel)
    acc = np.where(np.isnan(acc), ACCELERATION_PER_VELOCITY * vel, acc)
    bad = np.flatnonzero(~(pos[:, 0] < pos[:, 1]))
    if bad.size:
        j = int(bad[0])
        raise InputError(
            f"{arg('position')} limits of joint {j + 1} are [{pos[j, 0]:g}, {pos[j, 1]:g}] rad: "
            "the lower must be below the upper; no trajectory can meet them. Fix the limits "
            f"(URDF <limit lower upper> or {arg('position', '[[LO, HI], ...]', cli='LO,HI,...')})."
        )
    for name, arr in (("velocity", vel), ("acceleration", acc)):
        bad = np.flatnonzero(~(arr > 0) | ~np.isfinite(arr))
        if bad.size:
            j = int(bad[0])
            raise InputError(
                f"{arg(name)} limit of joint {j + 1} is {arr[j]:g}: it must be a positive finite "
                f"number, or the joint cannot move. Give {arg(name, '[...]', cli='LIST')}."
            )
    return {"position": pos, "velocity": vel, "acceleration": acc}


def random_excitation(model, rng, *, harmonics, period, q_start, limits, t, columns):
    """Condition number of one random Fourier trajectory scaled to the limits.

    Parameters
    ----------
    model : ChainModel
    rng : numpy.random.Generator
    harmonics : int
    period : float [s]
    q_start : array_like, shape (n_joints,) [rad]
    limits : dict
        As returned by `excitation_limits`.
    t : ndarray [s]
        Grid on which the limits are met and the criterion is evaluated.
    columns : array_like of int
        Base columns of the standard regressor.

    Returns
    -------
    (float, ndarray)
        The column-scaled condition number, and the free coefficients drawn (N(0, 1)).
    """
    nj = int(model.n_joints)
    free = rng.normal(size=nj * 2 * (harmonics - 1))
    _, q, qd, qdd = _scaled(free, nj, harmonics, period, t, q_start, limits)
    return _criteria(model, columns, q, qd, qdd)[0], free


def _start_position(q_start, pos, nj):
    """(start, whether it is a design variable); the default start is 0 clipped into range."""
    if q_start is None or (isinstance(q_start, str) and q_start == "optimise"):
        qs = np.clip(np.zeros(nj), pos[:, 0], pos[:, 1])
        qs = np.where((qs > pos[:, 0]) & (qs < pos[:, 1]), qs, pos.mean(axis=1))
        return qs, q_start is not None
    if isinstance(q_start, str):
        raise InputError(
            f"{arg('q_start')} must be None, 'optimise' or {nj} angles [rad]; got {q_start!r}."
        )
    qs = np.asarray(q_start, dtype=float).reshape(-1)
    if qs.size != nj:
        raise InputError(f"{arg('q_start')} must hold {nj} angles [rad]; got {qs.size}.")
    outside = np.flatnonzero(~((qs > pos[:, 0]) & (qs < pos[:, 1])))
    if outside.size:
        j = int(outside[0])
        raise InputError(
            f"{arg('q_start')} of joint {j + 1} is {qs[j]:g} rad, outside its position limits "
            f"[{pos[j, 0]:g}, {pos[j, 1]:g}]: no trajectory can start there. Choose "
            f"{arg('q_start')} inside the limits."
        )
    return qs, False


def design_excitation(
    model,
    *,
    harmonics: int = 5,
    period: float = 10.0,
    criterion: str = "cond",
    position=None,
    velocity=None,
    acceleration=None,
    q_start=None,
    n_random: int = 20,
    n_starts: int = 4,
    n_grid: int | None = None,
    max_iter: int = 400,
    max_seconds: float = 60.0,
    seed: int = 0,
) -> ExcitationDesign:
    """Design a Fourier excitation that minimises the base regressor's condition number.

    Parameters
    ----------
    model : ChainModel
        With ``regressor`` and ``base_parameters()``.
    harmonics : int
        H ≥ 2 harmonics per joint.
    period : float [s]
        T; the fundamental is 1/T Hz.
    criterion : {"cond", "logdet"}
        Minimise the column-scaled condition number, or maximise log det of the column-scaled
        information matrix (D-optimal).
    position : array_like (n, 2) [rad], optional
    velocity, acceleration : array_like (n,) [rad/s], [rad/s²], optional
        Limits (default: `model.limits`, then the defaults of `excitation_limits`).
    q_start : array_like (n,) [rad] or "optimise", optional
        Rest position at both ends (default: 0 clipped into the position range, where a robot
        — and `physid.simulate.simulate_closed_loop`, whose default initial state is zero —
        starts). ``"optimise"`` makes it a design variable searched inside the position limits
        (the trajectory then starts away from zero: move the robot there first, or pass
        ``q0=design.q_start`` to the simulator). The random baselines always start at the
        default.
    n_random : int
        Random trajectories to compare with (the best of them are the starts).
    n_starts : int
        Optimiser starts (the best ``n_starts`` random trajectories).
    n_grid : int, optional
        Samples per period of the search grid, where the limits are imposed and the criterion
        is minimised (default 16 H). The result is verified on ``4 n_grid`` samples (condition
        numbers, designed and random alike) and ``20 n_grid`` (limits).
    max_iter : int
        SLSQP iterations per start at most.
    max_seconds : float [s]
        Wall-time budget of the search, shared by the starts (checked after each iteration; the
        best point so far is kept).
    seed : int

    Returns
    -------
    ExcitationDesign

    Raises
    ------
    InputError
        Limits that cannot be met (see `excitation_limits`), a start outside the position
        range, bad settings.

    Notes
    -----
    Each SLSQP iteration evaluates n_v + 1 trajectories (n_v = n_joints (2H − 1) variables) in
    one batched regressor call; its peak memory is about (n_v + 1) · n_grid · n_joints ·
    n_standard · 8 bytes, capped at `BATCH_BYTES` by chunking (arm6, H = 5, n_grid = 80:
    55 · 80 · 6 · 78 · 8 B ≈ 16 MB).
    """
    from ..estimators.idim import base_regressor_info

    start_time = time.perf_counter()
    H = _check_design_settings(harmonics, period, criterion, n_random, n_starts, max_iter)
    nj = int(model.n_joints)
    limits = excitation_limits(
        model, position=position, velocity=velocity, acceleration=acceleration
    )
    pos = limits["position"]
    qs, free_start = _start_position(q_start, pos, nj)
    n_grid = int(n_grid or 16 * H)
    if n_grid < 4 * H:
        raise InputError(
            f"{arg('n_grid')} must be at least 4·{arg('harmonics')} = {4 * H}; got {n_grid}."
        )
    t = np.linspace(0.0, float(period), n_grid, endpoint=False)
    t_check = np.linspace(0.0, float(period), 4 * n_grid, endpoint=False)
    n_fine = 20 * n_grid
    t_fine = np.linspace(0.0, float(period), n_fine, endpoint=False)
    columns = base_regressor_info(model).columns

    # baselines, on the verification grid
    rng = np.random.default_rng(seed)
    randoms, within, unscaled, candidates = _random_baselines(
        model, columns, rng, n_random, H, period, t_check, t_fine, qs, limits
    )
    search = _Search(model, columns, H, period, t, nj, criterion)
    results = _search_from_starts(
        search, period, limits, qs, free_start, candidates, randoms, n_starts, max_iter, n_fine,
        start_time + float(max_seconds),
    )  # fmt: skip
    _, c, q0, _ = min(results, key=lambda r: r[0])
    per_start = [min(r[0] for r in results if r[3] == i) for i in sorted({r[3] for r in results})]
    q, qd, qdd = fourier_trajectory(c, t_check, period, q0)
    cond, logdet = _criteria(model, columns, q, qd, qdd)
    designed_unscaled = _unscaled_cond(model, columns, q, qd, qdd)
    qf, qdf, qddf = fourier_trajectory(c, t_fine, period, q0)
    return ExcitationDesign(
        period=float(period),
        harmonics=H,
        coefficients=c,
        q_start=q0,
        condition_number=cond,
        log_det=logdet,
        random_condition_numbers=randoms,
        criterion=criterion,
        limits=limits,
        peak={
            "position": np.abs(qf - q0).max(axis=0),
            "velocity": np.abs(qdf).max(axis=0),
            "acceleration": np.abs(qddf).max(axis=0),
            "q_min": qf.min(axis=0),
            "q_max": qf.max(axis=0),
        },
        seconds=time.perf_counter() - start_time,
        nfev=search.nfev,
        random_within_condition_numbers=np.array(within),
        starts=tuple(float(v) for v in per_start),
        unscaled={"designed": designed_unscaled, "random_median": float(np.median(unscaled))},
        n_check=int(t_check.size),
    )


def _check_design_settings(harmonics, period, criterion, n_random, n_starts, max_iter) -> int:
    """Refuse bad settings of `design_excitation`; the number of harmonics H."""
    if isinstance(harmonics, bool) or int(harmonics) != harmonics or int(harmonics) < 2:
        raise InputError(f"{arg('harmonics')} must be an integer ≥ 2; got {harmonics!r}.")
    H = int(harmonics)
    if not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0):
        raise InputError(f"{arg('period')} must be a positive number of seconds; got {period!r}.")
    if criterion not in ("cond", "logdet"):
        raise InputError(f"{arg('criterion')} must be 'cond' or 'logdet'; got {criterion!r}.")
    for name, value in (("n_random", n_random), ("n_starts", n_starts), ("max_iter", max_iter)):
        if isinstance(value, bool) or int(value) != value or int(value) < 1:
            raise InputError(f"{arg(name)} must be a positive integer; got {value!r}.")
    return H


def _random_baselines(model, columns, rng, n_random, H, period, t_check, t_fine, qs, limits):
    """Random trajectories scaled into the limits: their condition numbers (scaled, within the
    limits at random amplitudes, unscaled) on the verification grid, and their coefficients."""
    nj = int(model.n_joints)
    randoms, within, unscaled, candidates = [], [], [], []
    for _ in range(int(n_random)):
        free = rng.normal(size=nj * 2 * (H - 1))
        c, *_ = _scaled(free, nj, H, period, t_fine, qs, limits)
        q, qd, qdd = fourier_trajectory(c, t_check, period, qs)
        randoms.append(_criteria(model, columns, q, qd, qdd)[0])
        unscaled.append(_unscaled_cond(model, columns, q, qd, qdd))
        candidates.append(c)
        u = rng.uniform(0.0, 1.0, size=nj)
        q, qd, qdd = fourier_trajectory(c * u[:, None, None], t_check, period, qs)
        within.append(_criteria(model, columns, q, qd, qdd)[0])
    return np.array(randoms), within, unscaled, candidates
