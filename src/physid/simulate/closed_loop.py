"""Closed-loop PD simulation of chain models (Cedro & Janecki, section 4).

The controller is the paper's ``Mzr_k = Kp_k (M_k(t) − φ_k) − Kd_k φ̇_k``, i.e.
``τ = Kp (r − q) − Kd q̇`` per joint, and the closed loop ``M(q) q̈ + h(q, q̇) = τ`` is integrated
by `scipy.integrate.solve_ivp` (DOP853, rtol 1e-9, atol 1e-11 by default) with its dense output
sampled on a uniform grid. The right-hand side is the model's fused generated scalar code (PD law,
bias forces and an unrolled Cholesky solve of the mass matrix in one function), so a call costs a
few tens of microseconds and no numpy temporaries.

The paper's reference (section 4) are 0.5 rad steps at 1, 3, 5 and 7 s, passed through the
low-pass differential filter (M = 100, Ω_g = 0.025); the Mathematica code then stamps the
``n − 2M`` filtered samples ``tp1 = Δ Range[0, Length[Mf] − 1]``, i.e. from t = 0 although the
first one is centred on t = MΔ: the reference used in the simulation *leads* the raw step by
MΔ = 0.1 s. `paper_manipulator_experiment` reproduces this with ``paper=True`` (default);
``paper=False`` stamps every filtered sample at the centre of its window (zero phase).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from .._validate import as_1d, check_finite, check_positive, per_joint, sample_period
from ..errors import InputError, ShapeError, SimulationError
from ..signals.noise import add_white_noise
from .linear import uniform_time
from .pd import pd_rhs
from .recordings import ClosedLoopRecording
from .references import FilteredSteps, ReferenceTrajectory, filtered_steps, make_reference

__all__ = [
    "PAPER_MANIPULATOR",
    "ReferenceTrajectory",
    "make_reference",
    "closed_loop_rhs",
    "simulate_closed_loop",
    "paper_manipulator_experiment",
    "paper_reference",
]

#: The experiment of Cedro & Janecki, section 4.
PAPER_MANIPULATOR: dict[str, Any] = {
    "dt": 1e-3,  # Δ [s]
    "reference_end": 10.0,  # tk [s]: the raw steps are sampled on 0 .. tk
    "end_time": 9.7,  # tk − 0.3 [s]: the simulated horizon
    "step_times": (1.0, 3.0, 5.0, 7.0),  # [s]
    "step_height": 0.5,  # [rad]
    "half_width": 100,  # M [samples]
    "cutoff": 0.025,  # Ω_g [rad/sample]
    "kp": (3800.0, 40000.0, 10000.0, 500.0),  # [N·m/rad]
    "kd": (159.5, 120.0, 50.0, 2.0),  # [N·m·s/rad]
}


def paper_reference(paper: bool = True, *, dt: float = PAPER_MANIPULATOR["dt"]) -> FilteredSteps:
    """The filtered step references of Cedro & Janecki, section 4 (see the module docstring).

    Raw 0.5 rad steps at 1, 3, 5, 7 s (joints 1..4), sampled on 0 .. 10 s at `dt`, passed through
    the low-pass differential filter (M = 100, Ω_g = 0.025 rad/sample).

    Parameters
    ----------
    paper : bool
        True (default): stamp the filtered samples from t = 0, as the paper's code does
        (``tp1 = Δ Range[0, Length[Mf] − 1]``), so the reference *leads* the raw steps by
        M·Δ = 0.1 s. False: stamp each sample at the centre of its window (zero phase).
    dt : float [s]
        Sample period Δ (default 1 ms).

    Returns
    -------
    FilteredSteps
        ``t`` [s], shape (n_out,), ``values`` [rad], shape (n_out, 4), with
        n_out = 10/Δ + 1 − 2M (9801 at Δ = 1 ms), plus ``alignment`` and ``lead`` [s].
    """
    pm = PAPER_MANIPULATOR
    t_raw = uniform_time(duration=pm["reference_end"], dt=dt)
    return filtered_steps(
        t_raw,
        pm["step_times"],
        pm["step_height"],
        half_width=pm["half_width"],
        cutoff=pm["cutoff"],
        alignment="paper" if paper else "centred",
    )


# --------------------------------------------------------------------------- right-hand side
def _compiled_rhs(model, params, kp_a, kd_a, reference, coulomb_smoothing):
    """The compiled right-hand side, or None without a working C compiler.

    A rigid-body chain uses its generic C kernel (with the reference's spline when it is on a
    uniform grid); another model its equations compiled by `physid.simulate.compiled`.
    """
    if hasattr(model, "chain") and hasattr(model, "_c_kernel"):
        model.check_simulable(params)  # M(q)⁻¹ must exist (a massless link refuses)
        kernel = model._c_kernel()  # rigid-body chain: the generic C kernel
        if kernel is None:
            return None
        spline = None
        if isinstance(reference, ReferenceTrajectory) and reference.uniform_step is not None:
            spline = (
                float(reference.t[0]),
                float(reference.uniform_step),
                reference.coefficients,
                np.asarray(reference.values[0]),
                np.asarray(reference.values[-1]),
            )
        return kernel.pd_rhs(
            model.parameter_vector(params), kp_a, kd_a, reference, spline, coulomb_smoothing
        )
    from .compiled import compiled_pd_rhs

    return compiled_pd_rhs(model, params, kp_a, kd_a, reference)


def _pinocchio_rhs(model, params, kp_a, kd_a, reference, coulomb_smoothing):
    """The right-hand side by pinocchio's ABA on an equivalent model (benchmarks, checks)."""
    import pinocchio as pin

    from ..models.peers import pinocchio_model

    n = int(model.n_joints)
    if getattr(model, "kinetic", "exact") != "exact":
        raise InputError(
            "pinocchio computes the exact kinetic energy; the model uses "
            f"kinetic={model.kinetic!r}. Load it with kinetic='exact' to compare with "
            "pinocchio."
        )
    if hasattr(model, "chain"):
        from ..models.peers import to_pinocchio

        peer = to_pinocchio(model, params, coulomb_smoothing=coulomb_smoothing)
        pmodel, pdata = peer.model, peer.data
        drive = peer.drive_torque
    else:
        pmodel, pdata = pinocchio_model(model, params)
        drive = None
    aba = pin.aba

    def rhs_pin(t, y):
        q = y[:n]
        qd = y[n:]
        r = np.asarray(reference(t))
        tau = kp_a * (r - q) - kd_a * qd  # τ = Kp (r − q) − Kd q̇
        if drive is not None:
            tau = tau - drive(qd)
        return np.concatenate((qd, aba(pmodel, pdata, q, qd, tau)))

    rhs_pin.backend = "pinocchio"
    return rhs_pin


def closed_loop_rhs(
    model,
    *,
    kp,
    kd,
    reference: Callable,
    params=None,
    backend: str = "auto",
    coulomb_smoothing: float = 0.0,
):
    """The closed-loop right-hand side ``f(t, y) -> ẏ``, y = [q, q̇] (length 2 n_joints).

    Parameters
    ----------
    model : ChainModel
    kp, kd : array_like (n_joints,) [N·m/rad], [N·m·s/rad]
    reference : callable ``r(t) -> n_joints angles [rad]``
    params : dict or array, optional
        Model parameters (nominal values overridden).
    backend : {"auto", "compiled", "generated", "pinocchio"}
        ``"compiled"``: the model's equations as C compiled once and cached
        (`physid.simulate.compiled`); ``"generated"``: the model's fused generated Python scalar
        code with the PD law fused in (`physid.simulate.pd.pd_rhs`); ``"auto"``: compiled when
        a C compiler works, else generated. ``"pinocchio"``: pinocchio's ABA on an equivalent
        model (`physid.models.peers.pinocchio_model`), for benchmarks and checks.
    coulomb_smoothing : float [rad/s]
        Rigid-body models: Coulomb terms use tanh(q̇ / coulomb_smoothing) instead of sign(q̇)
        (0: exact). Other chain models ignore it.

    Returns
    -------
    callable
        ``f(t, y)``; its attribute ``backend`` names the implementation used.
    """
    n = int(model.n_joints)
    kp_a = per_joint(kp, "kp", n)
    kd_a = per_joint(kd, "kd", n)
    if backend not in ("auto", "compiled", "generated", "pinocchio"):
        raise InputError(
            f"backend must be 'auto', 'compiled', 'generated' or 'pinocchio'; got {backend!r}."
        )
    if backend in ("auto", "compiled"):
        fast = _compiled_rhs(model, params, kp_a, kd_a, reference, coulomb_smoothing)
        if fast is not None:
            fast.backend = "compiled"
            return fast
        if backend == "compiled":
            raise SimulationError(
                "the compiled right-hand side is unavailable: no working C compiler (cc, gcc or "
                "clang on PATH, or $CC) or the build failed. Use backend='generated'."
            )
        backend = "generated"
    if backend == "generated":
        fused = pd_rhs(
            model,
            params,
            kp=kp_a,
            kd=kd_a,
            reference=reference,
            coulomb_smoothing=coulomb_smoothing,
        )
        fused.backend = "generated"
        return fused
    if backend == "pinocchio":
        return _pinocchio_rhs(model, params, kp_a, kd_a, reference, coulomb_smoothing)


# --------------------------------------------------------------------------- simulation
def _initial_state(q0, qd0, n: int) -> np.ndarray:
    """The initial state [q, q̇] (zero where not given), checked: n finite values each."""
    y0 = np.zeros(2 * n)
    for name, value, sl in (("q0", q0, slice(0, n)), ("qd0", qd0, slice(n, 2 * n))):
        if value is not None:
            v = as_1d(value, name)
            if v.size != n:
                raise ShapeError(f"{name} must hold {n} values (one per joint); got {v.size}.")
            check_finite(v[:, None], name)
            y0[sl] = v
    return y0


def _run(model, theta, kp_a, kd_a, ref, params, backend, coulomb_smoothing, t, y0, method, rtol,
         atol):  # fmt: skip
    """Integrate the loop: by events when a rigid-body model has exact Coulomb friction, else
    in one `solve_ivp`.

    Returns the states (n_samples, 2n), the Coulomb statistics (None without events) and
    (nfev, backend used, the integrator's message).
    """
    coulomb = None
    if coulomb_smoothing == 0 and hasattr(model, "chain"):
        from .coulomb import coulomb_limits, integrate_coulomb

        if coulomb_limits(model, theta)[3].any():  # exact Coulomb law: event-driven
            y, coulomb = integrate_coulomb(
                model, theta, kp=kp_a, kd=kd_a, reference=ref, t=t, y0=y0, method=method,
                rtol=rtol, atol=atol, backend=backend, closed_loop_rhs=closed_loop_rhs,
            )  # fmt: skip
    if coulomb is None:
        y, sol = _integrate(model, kp_a, kd_a, ref, params, backend, coulomb_smoothing, t, y0,
                            method, rtol, atol)  # fmt: skip
        nfev, used, message = int(sol.nfev), sol.backend, str(sol.message)
    else:
        nfev, used, message = coulomb.pop("nfev"), coulomb.pop("backend"), "event-driven Coulomb"
    return y, coulomb, (nfev, used, message)


def _metadata(model, theta, kp_a, kd_a, coulomb_smoothing, coulomb, period, integrator):
    """The recording's metadata: the model, its parameters, the gains and the integrator."""
    return {
        "simulator": "physid.simulate.simulate_closed_loop",
        "model": getattr(model, "name", type(model).__name__),
        "kinetic": getattr(model, "kinetic", None),
        "parameters": (
            dict(zip(model.parameter_names, np.asarray(theta, dtype=float).tolist(), strict=True))
            if theta is not None and hasattr(model, "parameter_names")
            else None
        ),
        "kp": kp_a.tolist(),
        "kd": kd_a.tolist(),
        "controller": "tau = Kp (r - q) - Kd qd",
        **({"coulomb_smoothing": float(coulomb_smoothing)} if hasattr(model, "chain") else {}),
        **(
            {"coulomb": {"law": "exact sign with stiction, event-driven", **coulomb}}
            if coulomb is not None
            else {}
        ),  # fmt: skip
        "dt": period,
        # no wall-clock time in "integrator": the metadata goes into the data file, and the
        # same run must give the same bytes (determinism); callers time the call themselves
        "integrator": integrator,
    }


def _joint_units(model) -> dict[str, str]:
    """Units per joint: a prismatic joint moves in m and is driven by a force in N."""
    units = {}
    for j, kind in enumerate(getattr(model, "joint_types", None) or (), start=1):
        lin = str(kind) == "prismatic"
        units.update(
            {f"q{j}": "m" if lin else "rad", f"qd{j}": "m/s" if lin else "rad/s",
             f"tau{j}": "N" if lin else "N*m", f"r{j}": "m" if lin else "rad"}
        )  # fmt: skip
    return units


def simulate_closed_loop(
    model,
    *,
    kp,
    kd,
    reference,
    t=None,
    duration: float | None = None,
    dt: float | None = None,
    q0=None,
    qd0=None,
    params=None,
    method: str = "DOP853",
    rtol: float = 1e-9,
    atol: float = 1e-11,
    noise_std=None,
    rng=None,
    backend: str = "auto",
    reference_grid=None,
    metadata: Mapping[str, Any] | None = None,
    coulomb_smoothing: float = 0.0,
    feedforward: str = "none",
) -> ClosedLoopRecording:
    """Simulate ``M(q) q̈ + h(q, q̇) = Kp (r − q) − Kd q̇`` and sample it on a uniform grid.

    Parameters
    ----------
    model : ChainModel
        Any chain model (``physid.load_model("manipulator")`` or a model file).
    kp : array_like (n_joints,) [N·m/rad]
    kd : array_like (n_joints,) [N·m·s/rad]
    reference : callable, ReferenceTrajectory, FilteredSteps or array
        r(t) [rad]: a callable returning n_joints values, a constant (n_joints,), samples
        (n_samples, n_joints) on ``reference_grid`` (default: the output grid ``t``) joined by a
        C² cubic spline, or a `FilteredSteps`. Held constant outside its samples.
    t : array_like (n_samples,) [s], optional
        Uniform output grid starting at the initial time; or ``duration`` and ``dt``.
    q0, qd0 : array_like (n_joints,) [rad], [rad/s], optional
        Initial state (default zero).
    params : dict or array, optional
        Model parameters.
    method, rtol, atol :
        `scipy.integrate.solve_ivp` settings (DOP853, 1e-9, 1e-11 by default).
    noise_std : float or array_like (n_joints,) [rad], optional
        White Gaussian measurement noise added to the recorded q (not to q̇ or τ, and not fed
        back: the controller acts on the true state).
    rng : None, int, SeedSequence or Generator
        Noise source; the same seed gives the same bits.
    backend : {"auto", "compiled", "generated", "pinocchio"}
        Right-hand side implementation (see `closed_loop_rhs`); the one used is in the metadata.
    coulomb_smoothing : float [rad/s]
        Rigid-body models with Coulomb friction. 0 (default): the exact law the IDIM regressor
        writes, Fc·sign(q̇), with stiction at q̇ = 0 (static limit = kinetic), integrated by
        events (`physid.simulate.coulomb`: each segment smooth, a switch at every velocity
        reversal or stick/slip change; the number of switches and each joint's time stuck are
        in the metadata). > 0: the smoothed law Fc·tanh(q̇ / coulomb_smoothing) in one
        integration (a smoothing of 0.01 rad/s already biases an IDIM fit of Fc and Fv by
        several per cent). Recorded in the metadata.
    feedforward : {"none", "gravity", "gravity+friction"}
        Rigid-body models: the controller adds the model's gravity torque g(q) (and friction
        τ_f(q̇)) at the simulated parameters to the PD law (`physid.simulate.feedforward`);
        the law simulated is the metadata's ``controller``.

    Returns
    -------
    ClosedLoopRecording
        A `Recording` whose ``plot()`` draws the joint responses: ``q1..qn`` [rad],
        ``qd1..qdn`` [rad/s], ``tau1..taun`` [N·m] (the PD torques applied, computed from the
        true state), ``r1..rn`` [rad]; metadata with the gains, the parameters,
        the integrator settings and statistics (nfev; no wall-clock time, so that the same run
        writes the same bytes).

    Raises
    ------
    SimulationError
        When the integrator fails; the message says which setting to change.
    """
    if rng is not None and noise_std is None:
        raise InputError(
            f"rng={rng!r} only seeds the measurement noise on q, and none was asked for; give "
            "noise_std [rad], or drop the seed (the simulation itself is deterministic)."
        )
    n = int(model.n_joints)
    t = uniform_time(t, duration=duration, dt=dt)
    period = sample_period(t, "t")
    kp_a = per_joint(kp, "kp", n)
    kd_a = per_joint(kd, "kd", n)
    ref_grid = t if reference_grid is None else as_1d(reference_grid, "reference_grid")
    ref = make_reference(reference, n, ref_grid)
    y0 = _initial_state(q0, qd0, n)
    check_positive(rtol, "rtol")
    check_positive(atol, "atol")
    theta = model.parameter_vector(params) if hasattr(model, "parameter_vector") else params
    if not (np.isfinite(coulomb_smoothing) and coulomb_smoothing >= 0):
        raise InputError(
            f"coulomb_smoothing must be a velocity >= 0 [rad/s]; got {coulomb_smoothing!r}."
        )
    from .feedforward import FEEDFORWARD, compensated_plant, feedforward_torque

    plant, plant_theta = compensated_plant(model, theta, feedforward)
    y, coulomb, (nfev, used, message) = _run(
        plant, plant_theta, kp_a, kd_a, ref, params if plant is model else plant_theta, backend,
        coulomb_smoothing, t, y0, method, rtol, atol,
    )  # fmt: skip
    q, qd = y[:, :n], y[:, n:]
    if not np.all(np.isfinite(y)):
        raise SimulationError("the simulated state is not finite; the closed loop is unstable.")
    r = ref.sample(t) if isinstance(ref, ReferenceTrajectory) else np.array([ref(tk) for tk in t])
    tau = kp_a * (r - q) - kd_a * qd  # τ = Kp (r − q) − Kd q̇, on the true state
    tau = tau + feedforward_torque(model, theta, feedforward, q, qd)  # + g(q) [+ τ_f(q̇)]

    meta = _metadata(
        model, theta, kp_a, kd_a, coulomb_smoothing, coulomb, period,
        {"method": method, "rtol": rtol, "atol": atol, "nfev": nfev, "backend": used,
         "message": message},
    )  # fmt: skip
    q_meas = q
    if noise_std is not None:
        q_meas, _ = add_white_noise(q, std=noise_std, rng=rng)  # checks: one std or one per joint
        meta["noise"] = {
            "kind": "white Gaussian, added to q only",
            "std": as_1d(noise_std, "noise_std").tolist(),
            "seed": int(rng) if isinstance(rng, (int, np.integer)) else None,
        }
    meta["controller"] = FEEDFORWARD[feedforward]
    meta["feedforward"] = feedforward  # validate re-simulates the same controller
    meta.update(dict(metadata or {}))
    units = _joint_units(model)
    return ClosedLoopRecording.from_columns(
        t,
        {"q": q_meas, "qd": qd, "tau": tau, "r": r},
        units=units or {"q": "rad", "qd": "rad/s", "tau": "N*m", "r": "rad"},
        metadata=meta,
    )


def _integrate(model, kp_a, kd_a, ref, params, backend, coulomb_smoothing, t, y0, method, rtol,
               atol):  # fmt: skip
    """One `solve_ivp` over the whole grid; returns (y (n_samples, 2n), sol with ``backend``)."""
    rhs = closed_loop_rhs(
        model,
        kp=kp_a,
        kd=kd_a,
        reference=ref,
        params=params,
        backend=backend,
        coulomb_smoothing=coulomb_smoothing,
    )
    try:
        sol = solve_ivp(
            rhs, (float(t[0]), float(t[-1])), y0, method=method, t_eval=t, rtol=rtol, atol=atol
        )
    except ValueError as exc:  # bad method name or tolerances
        raise InputError(f"solve_ivp rejected the settings: {exc}") from None
    if sol.status != 0 or sol.y.shape[1] != t.size:
        reached = float(sol.t[-1]) if sol.t.size else float(t[0])
        raise SimulationError(
            f"the {method} integrator stopped at t = {reached:.6g} s of {t[-1]:.6g} s: "
            f"{sol.message} "
            "Check that the gains stabilise the arm, loosen rtol/atol, or try method='Radau' "
            "for a stiff "
            "loop (very high gains)."
        )
    sol.backend = getattr(rhs, "backend", backend)
    return sol.y.T, sol


def _load_manipulator(kinetic: str):
    from ..models import load_model

    return load_model("manipulator", kinetic=kinetic)


def paper_manipulator_experiment(
    kinetic: str | None = None,
    paper: bool = True,
    noise_std=None,
    seed=None,
    *,
    model=None,
    params=None,
    dt: float = PAPER_MANIPULATOR["dt"],
    end_time: float = PAPER_MANIPULATOR["end_time"],
    method: str = "DOP853",
    rtol: float = 1e-9,
    atol: float = 1e-11,
    backend: str = "auto",
) -> ClosedLoopRecording:
    """The closed-loop experiment of Cedro & Janecki, section 4, ready-made.

    Δ = 1 ms; references: 0.5 rad steps at 1, 3, 5, 7 s (joints 1..4) filtered by the low-pass
    differential filter (M = 100, Ω_g = 0.025); PD gains Kp = (3800, 40000, 10000, 500) N·m/rad,
    Kd = (159.5, 120, 50, 2) N·m·s/rad; zero initial state; end time tk − 0.3 = 9.7 s.

    Parameters
    ----------
    kinetic : {"exact", "paper"}, optional
        Kinetic energy of the model (see `physid.load_model`); default ``"exact"``. When
        `model` is given, `kinetic` may be left out; if both are given they must agree
        (``model.kinetic``), otherwise `InputError`.
    paper : bool
        True (default): stamp the filtered reference from t = 0 like the paper's
        ``tp1 = Δ Range[0, Length[Mf] − 1]``, so it leads the raw steps by MΔ = 0.1 s.
        False: stamp each filtered sample at the centre of its window (zero phase).
    noise_std : float or array_like (4,) [rad], optional
        White measurement noise on q.
    seed : None, int, SeedSequence or Generator
        Noise seed; only meaningful with `noise_std` (given alone it is an `InputError`).
    model : ChainModel, optional
        Use this model instead of loading ``"manipulator"``.
    params : dict or array, optional
        Model parameter overrides (default: m = 50, 25, 15, 5 kg; l = 0.4, 0.8, 0.6, 0.2 m).
    dt, end_time : float [s]
    method, rtol, atol, backend : integrator settings (see `simulate_closed_loop`).

    Returns
    -------
    Recording
        t, q1..q4, qd1..qd4, tau1..tau4, r1..r4 on 0 .. 9.7 s (9701 samples).
    """
    if seed is not None and noise_std is None:
        raise InputError(
            f"seed={seed!r} is used only to draw measurement noise, but noise_std was not given; "
            "pass noise_std=<rad> as well, or drop seed."
        )
    if model is None:
        model = _load_manipulator("exact" if kinetic is None else kinetic)
    elif kinetic is not None and getattr(model, "kinetic", None) != kinetic:
        raise InputError(
            f"kinetic={kinetic!r} conflicts with the model given, which has "
            f"kinetic={getattr(model, 'kinetic', None)!r}; drop kinetic= (the model decides) or "
            f"pass a model loaded with load_model('manipulator', kinetic={kinetic!r})."
        )
    pm = PAPER_MANIPULATOR
    ref = paper_reference(paper, dt=dt)
    t = uniform_time(duration=end_time, dt=dt)
    return simulate_closed_loop(
        model,
        kp=pm["kp"],
        kd=pm["kd"],
        reference=ref,
        t=t,
        params=params,
        method=method,
        rtol=rtol,
        atol=atol,
        noise_std=noise_std,
        rng=seed,
        backend=backend,
        metadata={
            "experiment": "Cedro & Janecki, section 4",
            "reference": {
                "step_times": list(pm["step_times"]),
                "step_height": pm["step_height"],
                "half_width": pm["half_width"],
                "cutoff": pm["cutoff"],
                "alignment": ref.alignment,
                "lead_seconds": ref.lead,
            },
        },
    )
