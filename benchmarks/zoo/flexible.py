"""A 2-link arm with elastic joints (Spong's reduced model), for the zoo's case (h).

The arm of `drives.TwoLink` (same links, gears, rotors, torque constant; its URDF) with a
torsion spring and damper between each gear's output and its link. With φ = θ/N the motor
angle seen through the gear (joint side) [rad], q the link angle, e = K (φ − q) + D (φ̇ − q̇)
the elastic torque [N·m]:

    link:   M(q) q̈ + c(q, q̇) + g(q) = e                       (M without the rotors)
    motor:  Ja φ̈ + Fv φ̇ + Fc tanh(φ̇/ε) + e = N kt i,  Ja = N² Jm

which is J_m θ̈ + friction_m(θ̇) + e/N = kt i multiplied by N, the motor friction written on the
joint side (friction_m(θ̇) = (Fv φ̇ + Fc tanh(φ̇/ε))/N, ε = 1e-3 rad/s on φ̇). Friction acts on
the motor, before the spring.

The rigid model the estimators fit. At frequencies well below the joint modes φ = q (up to
the static deflection K⁻¹ e: at rest 2.8 mrad at the shoulder, 3.7 mrad at the elbow) and the
two equations add up to the rigid arm with rotor inertia Ja as armature and joint-side viscous Fv and Coulomb Fc, the
values of `truth_of(..., arm.armature, arm.fv, arm.fc)`. Above the modes the motor moves
without the link and the motor current carries Ja φ̈ only.

Joint modes, default stiffness K = (3000, 250) N·m/rad (`modes`, linearised at the zoo's rest
pose q = (0.3, 0.6) rad with gravity's stiffness, D = 0): the coupled 4-DOF model's elastic
modes at 17.2 and 30.7 Hz (undamped); with the motors locked (φ fixed) the link modes at
10.6 and 26.1 Hz; the two slow modes (motors free, gravity's stiffness) at 0.32 and 0.48 Hz.
Per joint, decoupled (M12 = 0, no gravity): shoulder locked √(K1/M11)/2π = 13.7 Hz, free
√(K1 (1/M11 + 1/Ja1))/2π = 23.8 Hz; elbow 14.0 and 16.1 Hz; the inertia coupling M12 spreads
them. D = (1.5, 0.4) N·m·s/rad: damping ratios 0.071 and 0.076 of the two elastic modes.
``tests/test_zoo_flexible.py`` checks these against the simulator's own linearisation and a
free vibration it integrates.

Integrated by fixed-step RK4 (1e-4 s) with the current held over each controller period (2e-4
s). The inner loop is scalar Python: a state of 8 numbers is faster in floats than in numpy
arrays of length 2; a 20 s record takes about 5 s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .drives import G, TwoLink


@dataclass(frozen=True)
class FlexibleTwoLink:
    """``arm``: links, gears, rotors, kt and friction (its Fv, Fc; Stribeck off: Fs = Fc);
    ``stiffness`` K [N·m/rad] and ``damping`` D [N·m·s/rad] per joint, on the joint side."""

    arm: TwoLink = field(default_factory=lambda: TwoLink(fs=TwoLink().fc))
    stiffness: tuple = (3000.0, 250.0)
    damping: tuple = (1.5, 0.4)

    @property
    def links(self) -> TwoLink:
        """The rigid arm without rotors (the link side of the spring)."""
        a = self.arm
        return TwoLink(a.m, a.length, a.lc, a.inertia, a.ratio, a.kt, rotor=(0.0, 0.0))

    def gravity(self, q) -> np.ndarray:
        """g(q) (n, 2) [N·m]."""
        q = np.atleast_2d(q)
        return self.links.bias(q, np.zeros_like(q))

    def modes(self, q0) -> dict:
        """Undamped joint-mode frequencies [Hz] of the model linearised at rest at q0 (motor
        torque holding gravity, D = 0): ``free`` (the 2 elastic modes of the 4-DOF model),
        ``locked`` (motors fixed), ``pendulum`` (the 2 slow modes, motors free: gravity's
        stiffness against the whole inertia)."""
        q0 = np.asarray(q0, float)
        ml = self.links.mass_matrix(q0)[0]
        ja = self.arm.armature
        k = np.diag(self.stiffness)
        e = 1e-6
        gq = np.array(
            [(self.gravity(q0 + e * d) - self.gravity(q0 - e * d))[0] / (2 * e) for d in np.eye(2)]
        ).T  # ∂g/∂q
        m4 = np.zeros((4, 4))
        m4[:2, :2], m4[2:, 2:] = ml, np.diag(ja)
        k4 = np.block([[k + gq, -k], [-k, k]])
        w4 = np.sort(np.sqrt(np.abs(np.linalg.eigvals(np.linalg.solve(m4, k4)).real)))
        wl = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(ml, k + gq)).real))
        c4 = np.zeros((4, 4))
        dd = np.diag(self.damping)
        c4[:2, :2], c4[:2, 2:], c4[2:, :2], c4[2:, 2:] = dd, -dd, -dd, dd
        a8 = np.block(
            [[np.zeros((4, 4)), np.eye(4)], [-np.linalg.solve(m4, k4), -np.linalg.solve(m4, c4)]]
        )
        lam = np.linalg.eigvals(a8)
        lam = lam[lam.imag > 2 * np.pi * 2.0]  # the elastic pairs (the pendulum modes are < 1 Hz)
        lam = lam[np.argsort(lam.imag)]
        return {
            "free": w4[2:] / (2 * np.pi),
            "locked": wl / (2 * np.pi),
            "pendulum": w4[:2] / (2 * np.pi),
            "zeta": -lam.real / np.abs(lam),
        }

    def _deriv(self, s, tm):
        """ds/dt for s = (q1, q2, φ1, φ2, q̇1, q̇2, φ̇1, φ̇2) under motor torques tm = N kt i
        (scalars: this is the inner loop)."""
        a = self.arm
        m1, m2 = a.m
        l1 = a.length[0]
        c1, c2 = a.lc
        i1, i2 = a.inertia
        ja1, ja2 = a.ratio**2 * a.rotor[0], a.ratio**2 * a.rotor[1]
        k1, k2 = self.stiffness
        d1, d2 = self.damping
        q1, q2, p1, p2, v1, v2, w1, w2 = s
        e1 = k1 * (p1 - q1) + d1 * (w1 - v1)
        e2 = k2 * (p2 - q2) + d2 * (w2 - v2)
        s2, cq2 = math.sin(q2), math.cos(q2)
        a11 = i1 + i2 + m1 * c1 * c1 + m2 * (l1 * l1 + c2 * c2 + 2 * l1 * c2 * cq2)
        a12 = i2 + m2 * (c2 * c2 + l1 * c2 * cq2)
        a22 = i2 + m2 * c2 * c2
        h = -m2 * l1 * c2 * s2
        c12 = math.cos(q1 + q2)
        b1 = (
            e1
            - h * (2 * v1 * v2 + v2 * v2)
            + G * ((m1 * c1 + m2 * l1) * math.cos(q1) + m2 * c2 * c12)
        )
        b2 = e2 + h * v1 * v1 + G * m2 * c2 * c12
        det = a11 * a22 - a12 * a12
        f1 = a.fc[0] * math.tanh(w1 / a.eps) + a.fv[0] * w1
        f2 = a.fc[1] * math.tanh(w2 / a.eps) + a.fv[1] * w2
        return (
            v1, v2, w1, w2,
            (a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det,
            (tm[0] - f1 - e1) / ja1, (tm[1] - f2 - e2) / ja2,
        )  # fmt: skip

    def rk4(self, s, tm, dt):
        """One RK4 step of dt [s] from state s (8-tuple) with motor torques tm held."""
        f = self._deriv
        k1 = f(s, tm)
        k2 = f(tuple(x + 0.5 * dt * y for x, y in zip(s, k1, strict=True)), tm)
        k3 = f(tuple(x + 0.5 * dt * y for x, y in zip(s, k2, strict=True)), tm)
        k4 = f(tuple(x + dt * y for x, y in zip(s, k3, strict=True)), tm)
        return tuple(
            x + dt / 6 * (a + 2 * b + 2 * c + d)
            for x, a, b, c, d in zip(s, k1, k2, k3, k4, strict=True)
        )

    def energy(self, s) -> float:
        """Kinetic + gravity + spring energy [J] of state s (8 numbers)."""
        s = np.asarray(s, float)
        q, p, v, w = s[:2], s[2:4], s[4:6], s[6:]
        a = self.arm
        kin = 0.5 * v @ self.links.mass_matrix(q)[0] @ v + 0.5 * np.sum(a.armature * w**2)
        z1 = -a.lc[0] * math.sin(q[0])
        z2 = -a.length[0] * math.sin(q[0]) - a.lc[1] * math.sin(q[0] + q[1])
        spring = 0.5 * np.sum(np.asarray(self.stiffness) * (p - q) ** 2)
        return float(kin + G * (a.m[0] * z1 + a.m[1] * z2) + spring)

    def rest_state(self, q0) -> tuple:
        """At rest at link angles q0, the springs deflected by K⁻¹ g(q0) (the motors hold)."""
        g = self.gravity(q0)[0]
        p = np.asarray(q0, float) + g / np.asarray(self.stiffness)
        return (float(q0[0]), float(q0[1]), float(p[0]), float(p[1]), 0.0, 0.0, 0.0, 0.0)

    def simulate(self, r, h, kp, kd, counts, substeps=2, i_max=5.0, settle=1.0, disturbance=None):
        """PD loop at period h [s] on the motor encoder (``counts`` per motor turn), read on the
        joint side: τ = Kp (r − φ̃) − Kd (φ̃ − φ̃_prev)/h, i = τ/(N kt) clipped to ±i_max [A],
        held over the period; RK4 with ``substeps`` steps per period. ``disturbance`` (n, 2)
        [A], optional: a current the drive adds to the command (ripple, current-loop noise),
        part of the current the motor carries and the one returned. Starts at rest at r[0]
        (springs deflected) and holds it for ``settle`` s. Returns link angles q, motor angles
        φ = θ/N, their speeds (n, 2) each, the motor encoder θ̃ = N φ̃ [rad, motor side] and the
        current i (n, 2) [A]."""
        a = self.arm
        n = r.shape[0]
        step = 2 * np.pi / counts / a.ratio  # joint-side encoder step [rad]
        X, CUR = np.empty((n, 8)), np.empty((n, 2))
        ENC = np.empty((n, 2))
        s = self.rest_state(r[0])
        pq_prev = [round(x / step) * step for x in s[2:4]]
        dt = h / substeps
        kn = a.ratio * a.kt
        for k in range(-round(settle / h), n):
            rk = r[max(k, 0)]
            pq = [round(s[2] / step) * step, round(s[3] / step) * step]
            cur = [
                min(max((kp[j] * (rk[j] - pq[j]) - kd[j] * (pq[j] - pq_prev[j]) / h) / kn,
                        -i_max), i_max)
                for j in (0, 1)
            ]  # fmt: skip
            if k >= 0 and disturbance is not None:
                cur = [cur[0] + disturbance[k, 0], cur[1] + disturbance[k, 1]]
            if k >= 0:
                X[k], ENC[k], CUR[k] = s, pq, cur
            tm = (kn * cur[0], kn * cur[1])
            for _ in range(substeps):
                s = self.rk4(s, tm, dt)
            pq_prev = pq
        return X[:, :2], X[:, 2:4], X[:, 4:6], X[:, 6:], a.ratio * ENC, CUR
