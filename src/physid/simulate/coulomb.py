"""Exact Coulomb friction in closed-loop simulation: event-driven slip and stick.

The law simulated is the one the IDIM regressor writes, ``F(q̇) = Fc sign(q̇) + Fcp [q̇ > 0]
− Fcn [q̇ < 0] + OF`` (plus the viscous terms), completed at ``q̇ = 0`` by stiction (static limit
= the kinetic one): a joint at rest stays at rest while the friction torque it needs lies in
``[lo, hi] = [OF − Fc − Fcn, OF + Fc + Fcp]``.

A discontinuous right-hand side makes an explicit integrator crawl through every velocity
reversal (and chatter forever where a joint sticks), and smoothing the sign (``tanh(q̇/v_s)``)
changes the physics the data are meant to carry. Here instead the integration is split into
segments in which every Coulomb term is *frozen*: a slipping joint carries the constant torque
``hi`` (moving forward) or ``lo`` (backward), extended smoothly past ``q̇ = 0``; a stuck joint has
``q̇ = q̈ = 0`` and the friction torque that holds it (solved from the affine dependence of q̈ on
the friction torques). Events end a segment: a slipping joint's velocity reaching zero (it then
sticks, or reverses when the torque it would need exceeds the limits), or a stuck joint's
holding torque reaching a limit (it then slips that way). Each segment is smooth, so DOP853
keeps its order and its long steps.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from ..errors import InputError, SimulationError

__all__ = ["coulomb_limits", "integrate_coulomb"]

#: Most segments (events) a simulation may have before it is called chattering.
MAX_EVENTS = 200_000
#: Most switches in a row without the time advancing (Zeno: coupled joints flipping each other).
MAX_STALLED = 50


def coulomb_limits(model, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per joint the friction-torque limits ``lo``, ``hi`` [N·m], the offset ``OF`` and the mask of
    joints that carry a Coulomb law (``hi > lo``).

    Parameters
    ----------
    model : RigidBodyModel
    theta : array_like (n_parameters,)

    Returns
    -------
    lo, hi, offset : ndarray (n_joints,) [N·m]
    coulomb : ndarray of bool (n_joints,)
    """
    chain = model.chain
    n = chain.n_joints
    _, drive = chain.split(theta)
    names = chain.drive_names

    def col(name):
        return drive[:, names.index(name)] if name in names else np.zeros(n)

    fc, fcp, fcn, of = col("Fc"), col("Fcp"), col("Fcn"), col("OF")
    lo, hi = of - fc - fcn, of + fc + fcp
    return lo, hi, of, hi > lo


def _frozen_parameters(model, theta, coulomb):
    """θ with the Coulomb terms of the joints in ``coulomb`` zeroed (their torque is frozen)."""
    out = np.array(theta, dtype=float)
    names = list(model.parameter_names)
    for j in np.flatnonzero(coulomb):
        for d in ("Fc", "Fcp", "Fcn"):
            key = f"{d}{j + 1}"
            if key in names:
                out[names.index(key)] = 0.0
    return out


class _Loop:
    """``ẏ(t, y)`` of the closed loop with the Coulomb torques of some joints given (frozen)."""

    def __init__(self, model, theta0, kp, kd, reference, backend, closed_loop_rhs):
        n = int(model.n_joints)
        self.n = n
        self.extra = np.zeros(n)  # frozen friction torque minus OF, per joint [N·m]
        kernel = model._c_kernel() if backend in ("auto", "compiled") else None
        if kernel is not None:
            from ..models.ckernel import offset_slots

            fused = closed_loop_rhs(
                model, kp=kp, kd=kd, reference=reference, params=theta0, backend="compiled"
            )
            buf = fused.buffers[1]
            slots = offset_slots(n)
            base = buf[slots].copy()  # OF as the kernel holds it
            self.backend = "compiled"

            def f(t, y, extra):
                buf[slots] = base + extra
                return fused(t, y)

        else:
            if backend == "pinocchio":
                from ..models.peers import to_pinocchio

                accel = to_pinocchio(model, theta0).aba
            else:
                accel = model.make_rhs(theta0)
            self.backend = "pinocchio" if backend == "pinocchio" else "generated"

            def f(t, y, extra):
                q, qd = y[:n], y[n:]
                tau = kp * (np.asarray(reference(t)) - q) - kd * qd - extra
                return np.concatenate((qd, accel(q, qd, tau)))

        self._f = f

    def holding(self, t, y, stuck, extra):
        """ẏ with the joints in ``stuck`` held (q̈ = 0) and the extra torque that holds them."""
        idx = np.flatnonzero(stuck)
        e = extra.copy()
        e[idx] = 0.0
        d0 = self._f(t, y, e)
        if idx.size == 0:
            return d0, e
        n = self.n
        B = np.empty((idx.size, idx.size))
        for c, j in enumerate(idx):  # q̈ is affine in the friction torques: ∂q̈_S/∂f_j
            ej = e.copy()
            ej[j] = 1.0
            B[:, c] = self._f(t, y, ej)[n + idx] - d0[n + idx]
        try:
            f_s = np.linalg.solve(B, -d0[n + idx])
        except np.linalg.LinAlgError:
            raise SimulationError(
                f"the joints {(idx + 1).tolist()} are stuck by Coulomb friction at t = {t:.6g} s "
                "and the torques that hold them cannot be solved for (singular mass matrix)."
            ) from None
        e[idx] = f_s
        d = self._f(t, y, e)
        d[idx] = 0.0
        d[n + idx] = 0.0
        return d, e


class _Modes:
    """The slip/stick mode of each Coulomb joint: +1 / −1 slipping, 0 stuck.

    Holds the friction limits ``lo``, ``hi`` (offset ``of``) of the joints marked in
    ``coulomb``, decides a joint's mode when its rate reaches zero, and makes the events that
    end a segment of constant modes.
    """

    def __init__(self, loop, n: int, lo, hi, of, coulomb) -> None:
        self.loop, self.n = loop, n
        self.lo, self.hi, self.of, self.coulomb = lo, hi, of, coulomb
        self.mode = np.zeros(n, dtype=int)

    def frozen_extra(self) -> np.ndarray:
        """The friction torque of each slipping Coulomb joint (zero elsewhere)."""
        e = np.zeros(self.n)
        for j in np.flatnonzero(self.coulomb):
            if self.mode[j] > 0:
                e[j] = self.hi[j] - self.of[j]
            elif self.mode[j] < 0:
                e[j] = self.lo[j] - self.of[j]
        return e

    def decide(self, j: int, tnow: float, ynow: np.ndarray) -> int:
        """Joint j at q̇_j = 0: stuck if the torque holding it lies within [lo, hi]."""
        trial = (self.mode == 0) & self.coulomb
        trial[j] = True
        _, e = self.loop.holding(tnow, ynow, trial, self.frozen_extra())
        f = e[j] + self.of[j]
        if f >= self.hi[j]:
            return 1
        if f <= self.lo[j]:
            return -1
        return 0

    def initial(self, tc: float, y: np.ndarray) -> None:
        """The initial modes, from the initial rates (joints in the order of the chain)."""
        n = self.n
        for j in np.flatnonzero(self.coulomb):
            v = y[n + j]
            self.mode[j] = int(np.sign(v)) if v != 0 else 0
        for j in np.flatnonzero(self.coulomb & (y[n:] == 0)):
            self.mode[j] = self.decide(j, tc, y)

    def events(self, stuck: np.ndarray, base_extra: np.ndarray) -> tuple[list, list]:
        """The terminal events of a segment and what each means: ``(joint, "zero")`` for a
        slipping joint's rate reaching zero, ``(joint, ±1)`` for a stuck joint's holding torque
        reaching its upper or lower limit."""
        n, loop, of = self.n, self.loop, self.of
        evs, what = [], []
        for j in np.flatnonzero(self.coulomb):
            if self.mode[j] != 0:
                s = float(self.mode[j])

                def g(tt, yy, j=j, s=s):
                    return s * yy[n + j]

                g.terminal, g.direction = True, -1
                evs.append(g)
                what.append((j, "zero"))
            else:
                for side, lim in ((1, self.hi[j]), (-1, self.lo[j])):

                    def g(tt, yy, j=j, lim=lim, stuck=stuck, base_extra=base_extra):
                        e = loop.holding(tt, yy, stuck, base_extra)[1]
                        return e[j] + of[j] - lim

                    g.terminal, g.direction = True, side
                    evs.append(g)
                    what.append((j, side))
        return evs, what

    def switch(self, j: int, kind, tc: float, y: np.ndarray) -> None:
        """Apply the event ``(j, kind)`` at ``tc``: a rate at zero is held and decided again."""
        if kind == "zero":
            y[self.n + j] = 0.0
            self.mode[j] = self.decide(j, tc, y)
        else:
            self.mode[j] = int(kind)


def _solve(rhs, span, y, grid, evs, method, rtol, atol):
    """`scipy.integrate.solve_ivp` over one segment of constant modes, up to its first event."""
    try:
        return solve_ivp(
            rhs,
            span,
            y,
            method=method,
            t_eval=grid,
            rtol=rtol,
            atol=atol,
            events=evs or None,
        )
    except ValueError as exc:
        raise InputError(f"solve_ivp rejected the settings: {exc}") from None


def integrate_coulomb(
    model, theta, *, kp, kd, reference, t, y0, method, rtol, atol, backend, closed_loop_rhs
) -> tuple[np.ndarray, dict]:
    """Integrate the PD closed loop with exact Coulomb friction (slip and stick, see the module).

    Parameters
    ----------
    model : RigidBodyModel
    theta : array_like (n_parameters,)
    kp, kd : ndarray (n_joints,) [N·m/rad], [N·m·s/rad]
    reference : callable r(t) [rad]
    t : ndarray (n_samples,) [s]
        Output grid.
    y0 : ndarray (2 n_joints,)
        Initial [q, q̇].
    method, rtol, atol : `scipy.integrate.solve_ivp` settings (per segment).
    backend : {"auto", "compiled", "generated", "pinocchio"}
    closed_loop_rhs : callable
        `physid.simulate.closed_loop.closed_loop_rhs` (passed in: this module sits below it).

    Returns
    -------
    y : ndarray (n_samples, 2 n_joints)
    stats : dict
        ``nfev``, ``events`` (slip/stick switches), ``stick_time`` [s] per joint, ``backend``.

    Raises
    ------
    SimulationError
        Integrator failure, or more than `MAX_EVENTS` switches (chattering).
    """
    n = int(model.n_joints)
    lo, hi, of, coulomb = coulomb_limits(model, theta)
    theta0 = _frozen_parameters(model, theta, coulomb)
    loop = _Loop(model, theta0, kp, kd, reference, backend, closed_loop_rhs)
    modes = _Modes(loop, n, lo, hi, of, coulomb)
    out = np.empty((t.size, 2 * n))
    y = np.array(y0, dtype=float)
    tc = float(t[0])
    t_end = float(t[-1])
    filled = 0
    nfev = 0
    events = 0
    stalled = 0
    stick_time = np.zeros(n)
    modes.initial(tc, y)

    while True:
        stuck = (modes.mode == 0) & coulomb
        y[n + np.flatnonzero(stuck)] = 0.0
        base_extra = modes.frozen_extra()

        def rhs(tt, yy, stuck=stuck, base_extra=base_extra):
            return loop.holding(tt, yy, stuck, base_extra)[0]

        evs, what = modes.events(stuck, base_extra)
        sol = _solve(rhs, (tc, t_end), y, t[filled:], evs, method, rtol, atol)
        nfev += int(sol.nfev)
        k = int(np.size(sol.t))
        if k:
            out[filled : filled + k] = np.asarray(sol.y).T
        filled += k
        if sol.status == 0:
            stick_time[stuck] += t_end - tc
            break
        if sol.status != 1:
            raise SimulationError(
                f"the {method} integrator stopped at t = {float(np.ravel(sol.t)[-1]) if k else tc:.6g} s "
                f"of {t_end:.6g} s: {sol.message} Check that the gains stabilise the arm, or "
                "loosen rtol/atol."
            )
        hit = [(float(te[0]), c) for c, te in enumerate(sol.t_events) if te.size]
        te, c = min(hit)
        stick_time[stuck] += te - tc
        stalled = stalled + 1 if te - tc <= 1e-12 * max(1.0, abs(te)) else 0
        if stalled > MAX_STALLED:
            raise SimulationError(
                f"{stalled} Coulomb slip/stick switches at t = {te:.9g} s without the time "
                "advancing: the joints' friction limits hold each other (Zeno). Use "
                "coulomb_smoothing > 0 [rad/s] for this case."
            )
        y = np.array(sol.y_events[c][0], dtype=float)
        tc = te
        events += 1
        if events > MAX_EVENTS:
            raise SimulationError(
                f"more than {MAX_EVENTS} Coulomb slip/stick switches before t = {tc:.6g} s: the "
                "loop chatters. Use coulomb_smoothing > 0 [rad/s] for this case."
            )
        modes.switch(*what[c], tc, y)
        if tc >= t_end:
            break
    if filled != t.size:
        raise SimulationError(
            f"internal: the Coulomb-event integration filled {filled} of {t.size} samples."
        )
    return out, {
        "nfev": nfev,
        "events": events,
        "stick_time": stick_time.tolist(),
        "backend": loop.backend,
    }
