"""Optimal excitation for rigid-body identification: finite Fourier series (Swevers et al.).

Reference: Swevers, Ganseman, Tükel, De Schutter & Van Brussel, "Optimal robot excitation and
identification", IEEE Trans. Robotics and Automation 13(5), 1997.

Each joint follows a finite Fourier series of period T = 2π/ω_f with H harmonics::

    q_j(t) = q_start,j + s_j (φ_j(t) − φ_j(0)),
    φ_j(t) = Σ_{l=1}^{H}  a_jl/(l ω_f) sin(l ω_f t) − b_jl/(l ω_f) cos(l ω_f t)

so that q̇_j = s_j Σ_l (a_jl cos + b_jl sin), q̈_j = s_j ω_f Σ_l l (b_jl cos − a_jl sin). Starting
(and, by periodicity, ending) at rest: q̇(0) = Σ_l a_jl = 0 and q̈(0) = ω_f Σ_l l b_jl = 0; we
eliminate a_j1 and b_j1 with these two equations, leaving 2(H − 1) free coefficients per joint.

The limits are met by construction: for given coefficients the amplitude s_j is the largest
that keeps q within its position range (measured from q_start), |q̇| ≤ v_max and |q̈| ≤ a_max on
a fine grid, times a margin (0.98). The free coefficients then minimise the condition number of
the base regressor (columns scaled to unit norm, as `physid.estimators.idim.condition_number`)
on that grid, or maximise the log-determinant of its information matrix, with L-BFGS-B started
from the best of several random draws.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from ..errors import InputError

__all__ = [
    "ExcitationDesign",
    "design_excitation",
    "fourier_trajectory",
    "excitation_limits",
    "random_excitation",
]

#: Fraction of each limit the designed trajectory may use.
MARGIN = 0.98
#: Acceleration limit [rad/s²] used when neither the model nor the caller gives one, as a
#: multiple of the velocity limit [rad/s] (a URDF has no acceleration limits).
ACCELERATION_PER_VELOCITY = 5.0


@dataclass(frozen=True, eq=False)
class ExcitationDesign:
    """A designed excitation and how good it is.

    Attributes
    ----------
    period : float [s]
    harmonics : int
    coefficients : ndarray, shape (n_joints, 2, harmonics)
        ``a_jl`` (``[:, 0]``) and ``b_jl`` (``[:, 1]``) after scaling, [rad/s].
    q_start : ndarray, shape (n_joints,) [rad]
    condition_number : float
        Column-scaled condition number of the base regressor on the design grid.
    log_det : float
        log det of the column-scaled information matrix.
    random_condition_numbers : ndarray, shape (n_random,)
        The same for random Fourier trajectories under the same limits.
    criterion : str
    limits : dict
        ``position`` (n, 2), ``velocity`` (n,), ``acceleration`` (n,) used.
    peak : dict
        Largest |q − q_start|, |q̇|, |q̈| reached, per joint.
    seconds : float
        Wall time of the design.
    nfev : int
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

    @property
    def random_median(self) -> float:
        """Median condition number of the random trajectories."""
        return float(np.median(self.random_condition_numbers))

    @property
    def improvement(self) -> float:
        """``random_median / condition_number`` (how many times better the design is)."""
        return self.random_median / self.condition_number

    def trajectory(self, t):
        """q, q̇, q̈ at times t [s], each (n_samples, n_joints)."""
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
            "q_start": self.q_start.tolist(),
            "coefficients": self.coefficients.tolist(),
        }
        return Recording(t, np.column_stack([q, qd, qdd]), tuple(names), tuple(units), meta)

    def summary(self) -> str:
        """The achieved condition number against the random ones."""
        return (
            f"Fourier excitation: {self.harmonics} harmonics, period {self.period:g} s; "
            f"condition number {self.condition_number:.4g} vs median {self.random_median:.4g} "
            f"of {self.random_condition_numbers.size} random trajectories with the same limits "
            f"({self.improvement:.3g}× lower); {self.nfev} evaluations in {self.seconds:.3g} s."
        )


def fourier_trajectory(coefficients, t, period: float, q_start):
    """Evaluate the finite Fourier series of the module docstring.

    Parameters
    ----------
    coefficients : array_like, shape (n_joints, 2, H)
        ``a_jl``, ``b_jl`` [rad/s] (scale included).
    t : array_like, shape (n,) [s]
    period : float [s]
    q_start : array_like, shape (n_joints,) [rad]
        q(0).

    Returns
    -------
    q, qd, qdd : ndarray, each (n, n_joints) [rad], [rad/s], [rad/s²]
    """
    c = np.asarray(coefficients, dtype=float)
    t = np.asarray(t, dtype=float)
    H = c.shape[2]
    wf = 2.0 * np.pi / float(period)
    lw = wf * np.arange(1, H + 1)  # l ω_f
    arg = t[:, None] * lw[None, :]  # (n, H)
    s, co = np.sin(arg), np.cos(arg)
    a, b = c[:, 0, :], c[:, 1, :]  # (nj, H)
    phi = (s / lw) @ a.T - (co / lw) @ b.T
    phi0 = -(1.0 / lw) @ b.T
    q = np.asarray(q_start, dtype=float)[None, :] + phi - phi0[None, :]
    qd = co @ a.T + s @ b.T
    qdd = (-s * lw) @ a.T + (co * lw) @ b.T
    return q, qd, qdd


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
                f"{key}= must have shape {shape} (one entry per joint); got shape {arr.shape}."
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
            f"position= limits of joint {j + 1} are [{pos[j, 0]:g}, {pos[j, 1]:g}] rad: the lower "
            "must be below the upper; no trajectory can meet them. Fix the limits (URDF <limit "
            "lower upper> or position=)."
        )
    for name, arr in (("velocity", vel), ("acceleration", acc)):
        bad = np.flatnonzero(~(arr > 0) | ~np.isfinite(arr))
        if bad.size:
            j = int(bad[0])
            raise InputError(
                f"{name}= limit of joint {j + 1} is {arr[j]:g}: it must be a positive finite "
                f"number, or the joint cannot move. Give {name}= (CLI --{name} LIST)."
            )
    return {"position": pos, "velocity": vel, "acceleration": acc}


def _full_coefficients(free: np.ndarray, nj: int, H: int) -> np.ndarray:
    """a_j1 = −Σ_{l≥2} a_jl, b_j1 = −Σ_{l≥2} l b_jl / 1 (rest at t = 0); shape (nj, 2, H)."""
    x = free.reshape(nj, 2, H - 1)
    c = np.zeros((nj, 2, H))
    c[:, :, 1:] = x
    c[:, 0, 0] = -x[:, 0].sum(axis=1)
    c[:, 1, 0] = -(x[:, 1] * np.arange(2, H + 1)).sum(axis=1)
    return c


def _scaled(free, nj, H, period, t, q_start, limits):
    """Coefficients scaled to the largest amplitude meeting every limit, and the trajectory."""
    c = _full_coefficients(free, nj, H)
    q, qd, qdd = fourier_trajectory(c, t, period, np.zeros(nj))
    lo = limits["position"][:, 0] - q_start
    hi = limits["position"][:, 1] - q_start
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(q.max(axis=0) > 0, hi / q.max(axis=0), np.inf)
        down = np.where(q.min(axis=0) < 0, lo / q.min(axis=0), np.inf)
        sv = limits["velocity"] / np.abs(qd).max(axis=0)
        sa = limits["acceleration"] / np.abs(qdd).max(axis=0)
    s = MARGIN * np.nanmin(np.vstack([up, down, sv, sa]), axis=0)
    s = np.where(np.isfinite(s), s, 0.0)
    c = c * s[:, None, None]
    return c, q * s + q_start, qd * s, qdd * s


def _criteria(model, columns, q, qd, qdd) -> tuple[float, float]:
    """Column-scaled condition number and log det of the base regressor on the grid.

    From the eigenvalues of the column-scaled Gram matrix ``G = D WᵀW D`` (p × p): σ_i² = λ_i.
    Squaring costs digits only beyond a condition number of ~1e7, far above any design worth
    keeping, and a p × p eigenproblem is much cheaper than an SVD of the tall W (and immune to
    the BLAS thread oversubscription that makes a tall SVD 70× slower on a loaded machine).
    """
    Y = np.asarray(model.regressor(q, qd, qdd), dtype=float)[:, :, columns]
    a = Y.reshape(-1, Y.shape[-1])
    norms = np.linalg.norm(a, axis=0)
    if np.any(norms == 0):
        return float("inf"), -float("inf")
    an = a / norms
    lam = np.linalg.eigvalsh(an.T @ an)
    if lam[0] <= 0:
        return float("inf"), -float("inf")
    return float(np.sqrt(lam[-1] / lam[0])), float(np.sum(np.log(lam)))


def random_excitation(model, rng, *, harmonics, period, q_start, limits, t, columns):
    """Condition number of one random Fourier trajectory (coefficients N(0, 1), scaled)."""
    nj = int(model.n_joints)
    free = rng.normal(size=nj * 2 * (harmonics - 1))
    _, q, qd, qdd = _scaled(free, nj, harmonics, period, t, q_start, limits)
    return _criteria(model, columns, q, qd, qdd)[0], free


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
    n_grid: int | None = None,
    max_iter: int = 60,
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
    q_start : array_like (n,) [rad], optional
        Start (and end) position, at rest (default: 0 clipped into the position range).
    n_random : int
        Random trajectories to compare with (and to start from).
    n_grid : int, optional
        Samples per period where the limits and the criterion are evaluated (default 40 H).
    max_iter : int
        L-BFGS-B iterations at most.
    max_seconds : float [s]
        Wall-time budget of the optimiser (checked after each iteration; the best point so far
        is kept). Each iteration costs about 2·n_joints·(H − 1) + 1 evaluations of the base
        regressor on the grid (finite-difference gradient).
    seed : int

    Returns
    -------
    ExcitationDesign

    Raises
    ------
    InputError
        Limits that cannot be met (see `excitation_limits`), a start outside the position
        range, bad settings.
    """
    from ..estimators.idim import base_regressor_info

    start_time = time.perf_counter()
    if isinstance(harmonics, bool) or int(harmonics) != harmonics or int(harmonics) < 2:
        raise InputError(f"harmonics must be an integer ≥ 2; got {harmonics!r}.")
    H = int(harmonics)
    if not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0):
        raise InputError(f"period must be a positive number of seconds; got {period!r}.")
    if criterion not in ("cond", "logdet"):
        raise InputError(f"criterion must be 'cond' or 'logdet'; got {criterion!r}.")
    if int(n_random) < 1:
        raise InputError(f"n_random must be a positive integer; got {n_random!r}.")
    nj = int(model.n_joints)
    limits = excitation_limits(
        model, position=position, velocity=velocity, acceleration=acceleration
    )
    pos = limits["position"]
    if q_start is None:
        qs = np.clip(np.zeros(nj), pos[:, 0], pos[:, 1])
        qs = np.where((qs > pos[:, 0]) & (qs < pos[:, 1]), qs, pos.mean(axis=1))
    else:
        qs = np.asarray(q_start, dtype=float).reshape(-1)
        if qs.size != nj:
            raise InputError(f"q_start must hold {nj} angles [rad]; got {qs.size}.")
        outside = np.flatnonzero(~((qs > pos[:, 0]) & (qs < pos[:, 1])))
        if outside.size:
            j = int(outside[0])
            raise InputError(
                f"q_start of joint {j + 1} is {qs[j]:g} rad, outside its position limits "
                f"[{pos[j, 0]:g}, {pos[j, 1]:g}]: no trajectory can start there. Choose q_start "
                "inside the limits."
            )
    n_grid = int(n_grid or 25 * H)
    t = np.linspace(0.0, float(period), n_grid, endpoint=False)
    columns = base_regressor_info(model).columns
    rng = np.random.default_rng(seed)
    randoms, frees = [], []
    for _ in range(int(n_random)):
        cond, free = random_excitation(
            model, rng, harmonics=H, period=period, q_start=qs, limits=limits, t=t, columns=columns
        )
        randoms.append(cond)
        frees.append(free)
    randoms = np.array(randoms)
    x0 = frees[int(np.argmin(randoms))]
    counter = {"n": 0}

    def objective(x):
        counter["n"] += 1
        _, q, qd, qdd = _scaled(x, nj, H, period, t, qs, limits)
        cond, logdet = _criteria(model, columns, q, qd, qdd)
        if criterion == "cond":
            return math.log(cond) if math.isfinite(cond) else 1e3
        return -logdet if math.isfinite(logdet) else 1e3

    best = {"x": x0, "f": objective(x0)}
    deadline = time.perf_counter() + float(max_seconds)

    def callback(intermediate_result):
        if intermediate_result.fun < best["f"]:
            best["x"], best["f"] = np.array(intermediate_result.x), float(intermediate_result.fun)
        if time.perf_counter() > deadline:
            raise StopIteration

    sol = optimize.minimize(
        objective,
        x0,
        method="L-BFGS-B",
        callback=callback,
        options={"maxiter": int(max_iter), "eps": 1e-6},
    )
    x = sol.x if sol.fun <= best["f"] else best["x"]
    c, q, qd, qdd = _scaled(x, nj, H, period, t, qs, limits)
    fine = np.linspace(0.0, float(period), 20 * n_grid, endpoint=False)
    qf, qdf, qddf = fourier_trajectory(c, fine, period, qs)
    # the grid may miss a peak between its points: rescale on a 20× finer grid if needed
    ratio = np.max(
        np.vstack(
            [
                np.abs(qdf).max(axis=0) / limits["velocity"],
                np.abs(qddf).max(axis=0) / limits["acceleration"],
                np.where(qf.max(axis=0) > pos[:, 1], (qf.max(axis=0) - qs) / (pos[:, 1] - qs), 0),
                np.where(qf.min(axis=0) < pos[:, 0], (qf.min(axis=0) - qs) / (pos[:, 0] - qs), 0),
            ]
        ),
        axis=0,
    )
    shrink = np.where(ratio > 1.0, 1.0 / ratio, 1.0)
    c = c * shrink[:, None, None]
    q, qd, qdd = fourier_trajectory(c, t, period, qs)
    cond, logdet = _criteria(model, columns, q, qd, qdd)
    qf, qdf, qddf = fourier_trajectory(c, fine, period, qs)
    return ExcitationDesign(
        period=float(period),
        harmonics=H,
        coefficients=c,
        q_start=qs,
        condition_number=cond,
        log_det=logdet,
        random_condition_numbers=randoms,
        criterion=criterion,
        limits=limits,
        peak={
            "position": np.abs(qf - qs).max(axis=0),
            "velocity": np.abs(qdf).max(axis=0),
            "acceleration": np.abs(qddf).max(axis=0),
        },
        seconds=time.perf_counter() - start_time,
        nfev=counter["n"],
    )
