"""IDIM-IV: instruments from a simulated closed loop of the current estimate.

IDIM-IV replaces the noisy regressor in the normal equations by an instrument Z: the same base
regressor evaluated on a *simulated* closed loop of the current estimate (same controller,
same references ``r1..rn``), so that Z is correlated with W but not with the measurement noise:
``β̂_IV = (Zᵀ W)⁻¹ Zᵀ τ``, repeated with the new estimate until it stops changing (Janot,
Vandanjon & Gautier, IEEE TCST 2014). The simulated q goes through the same state filter,
regressor, parallel filter and decimation as the measured q (`.rows`).

The controller is the one that ran: PD, or PD plus the model's gravity (and friction)
feed-forward (`physid.simulate.feedforward`), from the ``feedforward`` argument or the
recording's metadata (``physid simulate --feedforward`` writes it).

Which gravity the simulated compensation uses. The logged loop is
``M(q; θ) q̈ + h(q, q̇; θ) = Kp (r − q) − Kd q̇ + g(q; θ_c) [+ τ_f(q̇; θ_c)]`` with θ the plant
and θ_c the controller's model. The instruments must (i) be uncorrelated with the measurement
noise and (ii) be as correlated with the noise-free regressor as possible, i.e. the simulated q
should approach the noise-free logged q. A logged feed-forward torque ``g(q_meas(t); θ_c)`` is
a function of the *measured*, noisy position; fed into the simulation as an input it would
carry that noise into Z and break (i). The compensation is therefore recomputed inside the
simulation from the simulated state with the *current estimate*: ``g(q_sim; θ̂)``. When the
controller compensates with the plant's own parameters (θ_c = θ, as `simulate_closed_loop`
does), the simulated loop equals the logged one exactly as θ̂ → θ, so the instruments become
the noise-free regressor, as for pure PD. When θ_c differs from θ, the mismatch
``g(θ) − g(θ_c)`` is a disturbance the simulation lacks: the instruments stay noise-free, hence
the estimate stays consistent, only less efficient.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..._progress import Progress
from ..._validate import per_joint
from ...errors import InputError, ShapeError, SimulationError, arg
from .base_parameters import BaseInfo, base_regressor
from .decimation import parallel_decimate
from .filtering import states
from .solve import iv_solve

__all__ = [
    "controller",
    "describe_controller",
    "iv_iterations",
    "params_for_base",
    "IV_RTOL",
    "IV_ATOL",
]

#: Integrator tolerances of IV's closed-loop simulations (the instruments). Looser than
#: `simulate_closed_loop`'s defaults (1e-9, 1e-11): half the right-hand-side evaluations, and on
#: arm7 (12 s, σ_q = 1e-3) the IV estimate moves by 6e-10 relative (measured), far below its
#: standard errors.
IV_RTOL = 1e-7
IV_ATOL = 1e-9


def _gains_from(value, name: str, n: int, metadata: Mapping[str, Any]) -> np.ndarray | None:
    """PD gains (n,) from the argument, else the recording's metadata; None when neither."""
    if value is None:
        value = metadata.get(name)
    if value is None:
        return None
    return per_joint(value, name, n)


def _feedforward_of(value, meta: Mapping[str, Any], k: int) -> str:
    """The feed-forward kind: the argument, else the recording's metadata, else ``"none"``."""
    from ...simulate.feedforward import FEEDFORWARD

    kind = value if value is not None else meta.get("feedforward", "none")
    if not isinstance(kind, str) or kind not in FEEDFORWARD:
        where = (
            arg("feedforward", repr(kind), cli=str(kind))
            if value is not None
            else f"recording {k + 1}'s metadata feedforward={kind!r}"
        )
        raise InputError(
            f"{where}: the feed-forward must be one of {sorted(FEEDFORWARD)} (PD alone, PD + "
            "g(q), PD + g(q) + τ_f(q̇))."
        )
    return str(kind)


def controller(recs, nj: int, kp=None, kd=None, feedforward=None) -> list:
    """The controller of each recording: ``(kp, kd, r, feedforward)``; refuse when unknown.

    Parameters
    ----------
    recs : sequence of Recording
    nj : int
    kp, kd : array_like (n_joints,), optional
        PD gains [N·m/rad], [N·m·s/rad]; default: each recording's metadata ``kp``/``kd``.
    feedforward : {None, "none", "gravity", "gravity+friction"}
        The feed-forward added to the PD law; None: the metadata's ``feedforward``, else
        ``"none"``.

    Returns
    -------
    list of tuple
        ``(kp (nj,), kd (nj,), r (n_samples, nj), feedforward)`` per recording.
    """
    out = []
    for k, rec in enumerate(recs):
        meta = dict(rec.metadata)
        ff = _feedforward_of(feedforward, meta, k)
        kp_k = _gains_from(kp, "kp", nj, meta)
        kd_k = _gains_from(kd, "kd", nj, meta)
        refs = [f"r{j + 1}" for j in range(nj)]
        missing = [c for c in refs if c not in rec.names]
        if kp_k is None or kd_k is None or missing:
            what = []
            if kp_k is None:
                what.append(f"the proportional gains ({arg('kp', '[...]', cli='LIST')})")
            if kd_k is None:
                what.append(f"the derivative gains ({arg('kd', '[...]', cli='LIST')})")
            if missing:
                what.append(f"the reference channels {missing}")
            raise InputError(
                f"IDIM-IV simulates the closed loop, so it needs the controller; recording "
                f"{k + 1} lacks {' and '.join(what)}. Give {arg('kp', '[...]', cli='LIST')} "
                f"and {arg('kd', '[...]', cli='LIST')} and a recording with r1..rn, or use "
                f"{arg('method', repr('ols'), cli='idim-ols')}/"
                f"{arg('method', repr('wls'), cli='idim-wls')}."
            )
        out.append((kp_k, kd_k, rec.select(refs), ff))
    return out


def describe_controller(loops) -> str:
    """One sentence naming the controller(s) IV simulated (for the result's message).

    Parameters
    ----------
    loops : sequence of tuple
        The closed loops of `controller` (their fourth item is the feed-forward's name).

    Returns
    -------
    str
    """
    from ...simulate.feedforward import FEEDFORWARD

    laws = sorted({FEEDFORWARD[loop[3]] for loop in loops})
    est = " (feed-forward at the current estimate)" if any(lp[3] != "none" for lp in loops) else ""
    return f" IV simulated the controller {' and '.join(laws)}{est}."


def simulate_loop(simulate, model, loop, t, q_meas, theta, theta_nominal, notes):
    """The closed loop of the current estimate; shrunk towards the nominal model if needed.

    A poor estimate can have a mass matrix that is not positive definite somewhere on the
    trajectory (the simulation then fails); the instruments only need to be correlated
    with the regressor, so the parameters are moved towards the model's nominal values
    (θ = θ_nom + α (θ̂ − θ_nom), α = 1, ½, ¼, 0) until the loop can be simulated.
    """
    kp, kd, ref, feedforward = loop
    q0 = ref[0] if np.allclose(q_meas[0], ref[0], atol=1e-2) else q_meas[0]
    for alpha in (1.0, 0.5, 0.25, 0.0):
        params = theta_nominal + alpha * (theta - theta_nominal)
        try:
            sim = simulate(
                model,
                kp=kp,
                kd=kd,
                reference=ref,
                t=t,
                q0=q0,
                params=params,
                rtol=IV_RTOL,
                atol=IV_ATOL,
                feedforward=feedforward,  # g(q_sim; θ) [+ τ_f]: the module's docstring says why
            )
        except SimulationError:
            continue
        if alpha < 1.0:
            notes.append(
                f"IDIM-IV: the closed loop of the current estimate could not be simulated "
                f"(mass matrix not positive definite or unstable); the instruments used "
                f"{alpha:g}× the way from the nominal parameters to it."
            )
        return sim, params
    raise SimulationError(
        "IDIM-IV could not simulate the closed loop even with the model's nominal "
        "parameters; check the gains (kp=, kd=) and the references r1..rn."
    )


def instruments(model, info, recs, rows, loops, theta, theta_nominal, notes, differentiation):
    """Z: the base regressor rows of the simulated closed loop of θ, one recording at a time.

    Janot–Gautier: the simulated (noise-free) q goes through the *same* state filter,
    regressor, parallel filter and decimation as the measured q, so that Z carries the same
    filter distortion as W and differs from it by the noise only.
    """
    from ...simulate.closed_loop import simulate_closed_loop

    nj = int(model.n_joints)
    q_names = [f"q{j + 1}" for j in range(nj)]
    Zs = []
    for k, rec in enumerate(recs):
        t = np.asarray(rec.t, dtype=float)
        q_meas = rec.select(q_names)
        sim, _ = simulate_loop(
            simulate_closed_loop, model, loops[k], t, q_meas, theta, theta_nominal, notes
        )
        qs = sim.select(q_names)
        _, qf, qdf, qddf, _ = states(qs, rec.dt, differentiation, rows.cutoff, rows.half_width)
        Zk, _ = parallel_decimate(base_regressor(model, info.columns, qf, qdf, qddf), rows.decimate)
        if Zk.shape[0] != int(np.sum(rows.segments == k)):  # guard
            raise ShapeError("internal: instrument rows do not match the regressor rows")
        Zs.append(Zk)
    return np.concatenate(Zs)


def _note_reach(model, info, theta, beta, notes) -> None:
    """Note (once) when the simulated model cannot reach the current base estimate."""
    reached = info.from_standard(model.beta(theta))
    miss = float(np.max(np.abs(reached - beta) / np.maximum(np.abs(beta), 1e-9)))
    if miss > 1e-3 and not any(n.startswith("IDIM-IV: the model of") for n in notes):
        notes.append(
            "IDIM-IV: the model of the simulated closed loop reaches the current base "
            f"estimate only to a relative {miss:.2g} (it would need a negative mass, "
            "inertia, armature or friction); the instruments come from that model."
        )


def iv_iterations(model, info, recs, rows, loops, beta, weights, history, notes, settings):
    """Janot–Gautier iterations: simulate, build instruments, solve ZᵀW β = Zᵀτ.

    ``settings`` is ``(differentiation, max_iter, tol)``. Appends each estimate to ``history``
    and what happened to ``notes``; returns ``(beta, Z, changes)``: the kept estimate, its
    instruments and the relative change of each iteration.
    """
    differentiation, max_iter, tol = settings
    theta = np.asarray(model.parameter_vector(None), dtype=float)
    theta_nominal = theta.copy()
    changes: list[float] = []
    kept_instruments: list[np.ndarray] = []
    Z = None
    bar = Progress(int(max_iter), "IDIM-IV: simulating the loop", unit="iterations (at most)")
    for _ in range(int(max_iter)):
        bar.advance(1 if changes else 0)
        theta = params_for_base(model, info, beta, theta)
        _note_reach(model, info, theta, beta, notes)
        Z = instruments(
            model, info, recs, rows, loops, theta, theta_nominal, notes, differentiation
        )
        new = iv_solve(Z, rows.W, rows.tau, weights)
        change = float(
            np.linalg.norm((new - beta) / np.maximum(np.abs(new), 1e-12 + 1e-3 * np.abs(new).max()))
            / math.sqrt(new.size)
        )
        beta = new
        history.append(beta)
        kept_instruments.append(Z)
        changes.append(change)
        if change < tol:
            break
        if len(changes) >= 3 and changes[-1] > changes[-2] > changes[-3]:
            # diverging: the simulated loop of a poor estimate gives poor instruments
            best = int(np.argmin(changes))
            beta = history[len(history) - len(changes) + best]
            Z = kept_instruments[best]
            notes.append(
                "IDIM-IV diverged (relative change per iteration "
                + ", ".join(f"{c:.2g}" for c in changes)
                + f"); kept iteration {best + 1}. The starting estimate is too poor for the "
                "simulated loop: improve the excitation or lower the state-filter cutoff."
            )
            break
    bar.close()
    return beta, Z, changes


_SIGNED = re.compile(r"(mc[xyz]|XY|XZ|YZ|OF)\d+")


def params_for_base(model, info: BaseInfo, beta_base, theta0) -> np.ndarray:
    """Model parameters θ whose base parameters K β(θ) match ``beta_base`` (closest to θ0).

    For a model linear in its parameters this is ``θ0 + K⁺ (β̂ − K β(θ0))`` (one Gauss–Newton
    step is exact); otherwise a few `scipy.optimize.least_squares` iterations with a small pull
    towards θ0 along directions the base parameters leave free. Only parameters that cannot
    change sign keep it (a positive mass, diagonal inertia, armature, friction or length stays
    positive); first moments ``mc*``, products of inertia ``XY/XZ/YZ`` and offsets ``OF`` are
    free, so a base parameter that must change sign is reached exactly.
    """
    from scipy import optimize

    names = tuple(model.parameter_names)
    K = info.matrix
    target = np.asarray(beta_base, dtype=float)
    scale_b = np.maximum(np.abs(target), 1e-6 * max(np.abs(target).max(), 1e-12))
    theta0 = np.asarray(theta0, dtype=float)
    scale_t = np.where(theta0 != 0, np.abs(theta0), 1.0)

    def beta_of(th):
        return np.asarray(model.beta(dict(zip(names, th.tolist(), strict=True))), dtype=float)

    def fun(th):
        return np.concatenate(
            [(K @ beta_of(th) - target) / scale_b, 1e-4 * (th - theta0) / scale_t]
        )

    def jac(th):
        db = np.asarray(model.beta_jacobian(dict(zip(names, th.tolist(), strict=True))), float)
        return np.vstack([(K @ db) / scale_b[:, None], 1e-4 * np.diag(1.0 / scale_t)])

    signed = np.array([bool(_SIGNED.fullmatch(n)) for n in names], dtype=bool)
    positive = (theta0 > 0) & ~signed
    lower = np.where(positive, 1e-6 * theta0, -np.inf)
    sol = optimize.least_squares(
        fun, theta0, jac=jac, bounds=(lower, np.full(theta0.size, np.inf)), x_scale=scale_t
    )
    return sol.x
