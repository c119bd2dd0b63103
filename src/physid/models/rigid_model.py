"""`RigidBodyModel`: a `ChainModel` whose parameters are the standard rigid-body parameters.

Built from a URDF, a URDF sidecar TOML, or a TOML chain with rigid-body keys (full inertia,
prismatic joints, modified DH, drive terms). Its parameters θ are the regressor's own columns
(``m1 mcx1 … ZZ1 [Ia1 Fv1 …] m2 …``), so β(θ) = θ, τ = Y θ and ∂τ/∂θ = Y. Nothing is derived
symbolically: every function is Newton–Euler over arrays (`physid.models.rigid`), or the generic C
kernel (`physid.models.ckernel`) when a C compiler works.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import InputError, ModelFileError
from . import rigid
from .chain import ChainModel

__all__ = ["RigidBodyModel", "MOTOR_COULOMB_SMOOTHING"]

#: Smoothing velocity [rad/s, motor side] of motor-side Coulomb terms in exact-Coulomb simulation.
MOTOR_COULOMB_SMOOTHING = 1.0


class RigidBodyModel(ChainModel):
    """Serial rigid-body chain with full inertial parameters, linear in its parameters.

    Same interface as `ChainModel` (``inverse_dynamics``, ``mass_matrix``, ``bias_forces``,
    ``gravity_forces``, ``forward_dynamics``, ``parameter_jacobian``, ``regressor``, ``beta``,
    ``base_parameters``, ``make_rhs``, ``make_state_rhs``), plus `regressor_names`,
    `joint_types`, `limits` and `chain` (the numeric description). Joint positions are [rad] for
    revolute and [m] for prismatic joints; torques [N·m] or forces [N].

    Attributes
    ----------
    chain : RigidChain
    regressor_names : tuple of str
        Equal to `parameter_names` and `beta_names`.
    joint_types : tuple of str
    limits : dict
        ``position`` (n, 2), ``velocity`` (n,), ``effort`` (n,), ``acceleration`` (n,); NaN
        where unknown.
    """

    def __init__(self, chain: rigid.RigidChain, *, check: bool = True, cache: bool = True):
        start = time.perf_counter()
        self._chain = chain
        self._spec = chain
        self.name = chain.name
        ind = list(chain.independent)  # mimic joints follow their leaders: not coordinates
        self.n_joints = len(ind)
        self.parameter_names = chain.parameter_names()
        self._nominal = chain.nominal_vector()
        self.units = dict(zip(self.parameter_names, chain.parameter_units(), strict=True))
        if chain.identify:
            bad = [s for s in chain.identify if s not in self.parameter_names]
            if bad:
                raise ModelFileError(
                    f"{chain.source}: identify names unknown parameter(s) {bad}; the model's "
                    f"parameters are {list(self.parameter_names[: chain.per_joint])}... "
                    "(per joint: m, mcx, mcy, mcz, XX, XY, XZ, YY, YZ, ZZ, then drive terms)."
                )
            self.unknown = tuple(s for s in self.parameter_names if s in chain.identify)
        else:
            self.unknown = self.parameter_names
        self.kinetic = "exact"
        self.gravity = tuple(float(g) for g in chain.gravity)
        self.joint_names = tuple(chain.joint_names[i] for i in ind)
        self.joint_types = tuple(chain.joint_types[i] for i in ind)
        self.limits = {k: np.array(v, dtype=float)[ind] for k, v in chain.limits.items()}
        n = self.n_joints
        self.limits.setdefault("position", np.full((n, 2), np.nan))
        for key in ("velocity", "effort", "acceleration"):
            self.limits.setdefault(key, np.full(n, np.nan))
        self.loaded_from_cache = False
        self.cache_key = ""
        self._cache_enabled = bool(cache)
        self._base_cache: dict = {}
        self.base_from_cache = False
        self._regressor = None
        self._kernel = None
        self._kernel_tried = False
        #: Why M(q) is singular at the nominal parameters ("" when regular): such a model
        #: loads (identification needs the regressor, not M(q)⁻¹) and simulation refuses it.
        self.singular_reason = self._mass_matrix_problem(self._nominal) if check else ""
        if self.singular_reason:
            import warnings

            from .urdf import ModelWarning

            warnings.warn(
                f"{self.singular_reason} The model loads for identification (which needs the "
                "regressor, not M(q)⁻¹); simulating it needs an invertible M(q): give those "
                "links a mass and inertia, or the joint an armature (or a motor inertia).",
                ModelWarning,
                stacklevel=2,
            )
        self.load_seconds = time.perf_counter() - start

    # -- description ------------------------------------------------------------------------
    @property
    def chain(self) -> rigid.RigidChain:
        """The numeric description (placements, axes, nominal parameters, limits)."""
        return self._chain

    @property
    def spec(self):
        """The description this model was built from (a `RigidChain`)."""
        return self._chain

    @property
    def regressor_names(self) -> tuple:
        """Names of the regressor's columns (= `parameter_names`)."""
        return self.parameter_names

    @property
    def beta_names(self) -> tuple:
        """Names of β (= `parameter_names`: the model is linear in its parameters)."""
        return self.parameter_names

    def _repr_html_(self) -> str:
        """A notebook summary: joints (or input → output) and the nominal parameters."""
        from ._display import model_html

        return model_html(self)

    def __repr__(self) -> str:
        return (
            f"RigidBodyModel(name={self.name!r}, n_joints={self.n_joints}, "
            f"joint_types={self.joint_types}, n_parameters={len(self.parameter_names)})"
        )

    def _mass_matrix_problem(self, beta, what="the nominal parameters") -> str:
        """Why M(q) is singular at ``beta`` (random states), or "" when it is regular."""
        rng = np.random.default_rng(7)
        n = self.n_joints
        q = rng.uniform(-np.pi, np.pi, (4, n))
        for j, kind in enumerate(self.joint_types):
            if kind == "prismatic":
                q[:, j] = rng.uniform(0.0, 0.5, 4)
        M = rigid.mass_matrix(self._chain, beta, q)
        for s in range(M.shape[0]):
            ev = np.linalg.eigvalsh(M[s])
            scale = max(float(np.abs(ev).max()), 1e-300)
            if ev[0] <= 1e-12 * scale:
                d = np.diag(M[s])
                j = int(np.argmin(d))
                return (
                    f"{self._chain.source}: the mass matrix is singular at {what} "
                    f"(smallest eigenvalue {ev[0]:.3g}, largest {ev[-1]:.3g}): joint "
                    f"{j + 1} ({self.joint_names[j]!r}) moves no mass or inertia (a zero-length "
                    "link, a massless link, or a point mass on its axis)."
                )
        return ""

    def check_simulable(self, params=None) -> None:
        """Refuse to simulate where M(q) is singular (forward dynamics needs M(q)⁻¹).

        Parameters
        ----------
        params : dict or array_like, optional
            The parameters the simulation uses (default nominal).

        Raises
        ------
        ModelFileError
            M(q) is singular at those parameters, with the joint that moves no mass.
        """
        if not getattr(self, "singular_reason", ""):
            return
        beta = self.parameter_vector(params)
        problem = self._mass_matrix_problem(beta, "these parameters")
        if problem:
            raise ModelFileError(
                f"cannot simulate: {problem} Simulation solves M(q) q̈ = τ − h and needs an "
                "invertible M(q) (identification does not). Give those links a mass and "
                "inertia, or the joint an armature (Ia) or a motor inertia."
            )

    def joint_side_channels(self, names, column, source: str = "the recording") -> tuple:
        """Joint channels (q, tau) from motor-side ones (qm, taum, im) through the model's
        ``[transmission]`` (`physid.models.transmission.Transmission.joint_side`).

        Parameters
        ----------
        names : sequence of str
            Channel names of the recording.
        column : callable
            ``column(name) -> ndarray (n_samples,)``.
        source : str

        Returns
        -------
        (dict, dict)
            New columns and their units (a prismatic joint's in m and N); empty without a
            transmission or motor channels.
        """
        tr = self._chain.transmission
        if tr is None:
            return {}, {}
        prismatic = tuple(kind == "prismatic" for kind in self.joint_types)
        return tr.joint_side(names, column, source, prismatic)

    # -- kernels ----------------------------------------------------------------------------
    def _c_kernel(self):
        """The C kernel of the whole model, or None (no compiler, or motor-side terms, which
        the kernel's single-state functions do not hold: simulation then runs in numpy)."""
        if self._chain.motor_names:
            return None
        return self._core_kernel()

    def _core_kernel(self):
        """The C kernel of the rigid bodies and joint-side drive terms (batched functions)."""
        if self._chain.mimic:  # the kernel moves every joint on its own
            return None
        if not getattr(self, "_kernel_tried", False):
            self._kernel_tried = True
            from .ckernel import load_kernel

            self._kernel = load_kernel(self._chain)
        return self._kernel

    def _motor_torque(self, beta, QD, QDD):
        """Joint torques of the motor-side terms (zeros without a transmission)."""
        if not self._chain.motor_names:
            return 0.0
        return self._chain.transmission.torque(self._chain.motor_values(beta), QD, QDD)

    def _arrays(self, *pairs):
        n, cols = self._states(*pairs)
        return n, [np.ascontiguousarray(np.array(c).T) for c in cols]

    # -- dynamics ---------------------------------------------------------------------------
    def inverse_dynamics(self, q, qd, qdd, params=None) -> np.ndarray:
        """Joint torques τ = M(q) q̈ + C(q, q̇) q̇ + g(q) + τ_drive, shape (n_samples, n_joints).

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n_samples, n_joints)
            Joint positions [rad | m], velocities and accelerations.
        params : dict or array_like (n_parameters,), optional
            None: nominal; a dict overrides some; an array gives all (like `parameter_names`).

        Returns
        -------
        ndarray, shape (n_samples, n_joints) [N·m | N]
        """
        _, (Q, QD, QDD) = self._arrays((q, "q"), (qd, "qd"), (qdd, "qdd"))
        beta = self.parameter_vector(params)
        k = self._core_kernel()
        if k is not None:
            return k.rnea(beta, Q, QD, QDD) + self._motor_torque(beta, QD, QDD)
        return rigid.rnea(self._chain, beta, Q, QD, QDD)

    def mass_matrix(self, q, params=None) -> np.ndarray:
        """Mass matrix M(q), shape (n_samples, n_joints, n_joints), symmetric.

        Parameters
        ----------
        q : array_like, shape (n_samples, n_joints) [rad | m]
        params : dict or array_like, optional

        Returns
        -------
        ndarray (n_samples, n_joints, n_joints) [kg·m² | kg]
        """
        _, (Q,) = self._arrays((q, "q"))
        beta = self.parameter_vector(params)
        k = self._core_kernel()
        if k is not None:
            M = k.mass(beta, Q)
            if self._chain.motor_names:  # rotors: Kᵀ diag(Im) K
                M += self._chain.transmission.mass(self._chain.motor_values(beta))
            return M
        return rigid.mass_matrix(self._chain, beta, Q)

    def bias_forces(self, q, qd, params=None) -> np.ndarray:
        """h(q, q̇) = C(q, q̇) q̇ + g(q) + friction: τ at q̈ = 0, shape (n_samples, n_joints).

        Parameters
        ----------
        q, qd : array_like, shape (n_samples, n_joints)
        params : dict or array_like, optional

        Returns
        -------
        ndarray (n_samples, n_joints) [N·m | N]
        """
        _, (Q, QD) = self._arrays((q, "q"), (qd, "qd"))
        return self.inverse_dynamics(Q, QD, np.zeros_like(Q), params)

    def gravity_forces(self, q, params=None) -> np.ndarray:
        """g(q): the torque that holds the arm still (no friction or offset), (n_samples, n_joints).

        Parameters
        ----------
        q : array_like, shape (n_samples, n_joints)
        params : dict or array_like, optional

        Returns
        -------
        ndarray (n_samples, n_joints) [N·m | N]
        """
        _, (Q,) = self._arrays((q, "q"))
        beta = self.parameter_vector(params)
        z = np.zeros_like(Q)
        return rigid.rnea(self._chain, beta, Q, z, z, drive=False)

    def forward_dynamics(self, q, qd, tau, params=None) -> np.ndarray:
        """q̈ = M(q)⁻¹ (τ − h(q, q̇)), shape (n_samples, n_joints).

        Parameters
        ----------
        q, qd : array_like, shape (n_samples, n_joints)
        tau : array_like, shape (n_samples, n_joints) [N·m | N]
        params : dict or array_like, optional

        Returns
        -------
        ndarray (n_samples, n_joints)

        Raises
        ------
        InputError
            M(q) is singular at some sample.
        ModelFileError
            M(q) is singular at these parameters (`check_simulable`).
        """
        _, (Q, QD, TAU) = self._arrays((q, "q"), (qd, "qd"), (tau, "tau"))
        self.check_simulable(params)
        M = self.mass_matrix(Q, params)
        rhs = TAU - self.bias_forces(Q, QD, params)
        try:
            return np.linalg.solve(M, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise InputError(
                "the mass matrix is singular at some sample at these parameters: a joint moves no "
                "mass; check params (masses and inertias must be positive)."
            ) from None

    # -- linear-in-parameters form ----------------------------------------------------------
    def beta(self, params=None) -> np.ndarray:
        """β(θ) = θ (shape (n_parameters,)): the model is linear in its parameters.

        Parameters
        ----------
        params : dict or array_like, optional

        Returns
        -------
        ndarray (n_parameters,)
        """
        return self.parameter_vector(params)

    def beta_jacobian(self, params=None) -> np.ndarray:
        """∂β/∂θ = identity, shape (n_parameters, n_parameters).

        Parameters
        ----------
        params : dict or array_like, optional

        Returns
        -------
        ndarray (n_parameters, n_parameters)
        """
        return np.eye(len(self.parameter_names))

    def regressor(self, q, qd, qdd, *, out=None) -> np.ndarray:
        """Y(q, q̇, q̈), shape (n_samples, n_joints, n_parameters), with τ = Y @ θ.

        Evaluated in blocks of samples directly into the result, so the peak memory is one
        copy of Y plus ~1 MB of scratch.

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n_samples, n_joints)
        out : ndarray, optional
            Preallocated result (float64, C-contiguous, the shape above).

        Returns
        -------
        ndarray (n_samples, n_joints, n_parameters) [N·m per unit of each parameter]
        """
        n, (Q, QD, QDD) = self._arrays((q, "q"), (qd, "qd"), (qdd, "qdd"))
        shape = (n, self.n_joints, len(self.parameter_names))
        if out is not None and (out.shape != shape or out.dtype != np.float64):
            raise InputError(f"out must be a float64 array of shape {shape}; got {out.shape}.")
        k = self._core_kernel()
        if k is None:
            return rigid.regressor(self._chain, Q, QD, QDD, out=out)
        if not self._chain.motor_names:
            return k.regressor(Q, QD, QDD, out=out)
        if out is None:
            out = np.empty(shape)
        nb = self.n_joints * self._chain.per_joint
        out[:, :, :nb] = k.regressor(Q, QD, QDD)
        out[:, :, nb:] = self._chain.transmission.columns(QD, QDD)
        return out

    def regressor_columns(self, q, qd, qdd, columns, out) -> np.ndarray:
        """``Y(q, q̇, q̈)[:, :, columns]`` written into ``out`` without the whole Y in memory.

        Parameters
        ----------
        q, qd, qdd : ndarray, shape (n_samples, n_joints) [rad, rad/s, rad/s²]
        columns : sequence of int
            Regressor columns (of `parameter_names`).
        out : ndarray, shape (n_samples, n_joints, len(columns)), float64
            Written in place; its rows may be spaced wider than their values (a view of a
            wider array's leading columns).

        Returns
        -------
        ndarray
            ``out`` [N·m per unit of each parameter].
        """
        k = self._core_kernel()
        if (
            k is not None
            and not self._chain.motor_names
            and out.strides[1:]
            == (
                8 * out.shape[2],
                8,
            )
        ):
            n, (Q, QD, QDD) = self._arrays((q, "q"), (qd, "qd"), (qdd, "qdd"))
            return k.regressor_columns(Q, QD, QDD, columns, out)
        out[...] = np.asarray(self.regressor(q, qd, qdd))[:, :, np.asarray(columns, dtype=int)]
        return out

    def parameter_jacobian(self, q, qd, qdd, params=None) -> np.ndarray:
        """∂τ/∂θ = Y(q, q̇, q̈), shape (n_samples, n_joints, n_parameters).

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n_samples, n_joints)
        params : dict or array_like, optional
            Unused (the model is linear); checked.

        Returns
        -------
        ndarray (n_samples, n_joints, n_parameters)
        """
        self.parameter_vector(params)
        return self.regressor(q, qd, qdd)

    def _regressor_data(self) -> dict:
        n = len(self.parameter_names)
        return {
            "names": list(self.parameter_names),
            "keep": list(range(n)),
            "monomials": [[int(i == j) for j in range(n)] for i in range(n)],
            "exponents": np.eye(n),
        }

    def base_parameters(self, params=None, *, n_states=None, seed=0, rtol=None):
        """Base parameters: QR with column pivoting of Y stacked over random states.

        Cached: in memory on the model (the same object for the same settings) and on disk in
        the physid cache folder, keyed by a hash of the geometry the base set depends on
        (`physid.models._base_cache`); a disk entry is used only if it reproduces the regressor
        at fresh random states. ``base_from_cache`` says whether the last derivation was
        served from disk. The returned arrays are read-only.

        Parameters
        ----------
        params : dict or array_like, optional
            Unused for the base set (it depends only on the geometry); kept for the signature.
        n_states : int, optional
            Random states (default max(60, 2·n_parameters / n_joints + 20), as
            `physid.models.base.base_parameters_of_regressor`).
        seed : int
        rtol : float, optional
            Rank threshold on |R_kk| / |R_00| of the column-scaled regressor (default
            `physid.models.base.RANK_RTOL`, 1e-4: a column the others reproduce that closely is
            regrouped into them).

        Returns
        -------
        physid.models.base.BaseParameters
        """
        from ._base_cache import cached_base_parameters
        from .base import RANK_RTOL, base_parameters_of_regressor

        rtol = RANK_RTOL if rtol is None else rtol

        key = (None if n_states is None else int(n_states), int(seed), float(rtol))
        memo = getattr(self, "_base_cache", None)
        if memo is None:  # a model unpickled from an older layout
            memo = self._base_cache = {}
        if key in memo:
            return memo[key]

        def derive():
            return base_parameters_of_regressor(
                self, n_states=n_states, seed=seed, rtol=rtol, limits=self.limits
            )

        bp, hit = cached_base_parameters(
            self,
            derive,
            n_states=n_states,
            seed=seed,
            rtol=rtol,
            enabled=getattr(self, "_cache_enabled", False),
        )
        for name in ("base_matrix", "null_directions"):
            getattr(bp, name).setflags(write=False)
        self.base_from_cache = hit
        memo[key] = bp
        return bp

    # -- single-state right-hand sides ------------------------------------------------------
    def make_rhs(self, params=None, *, coulomb_smoothing: float = 0.0):
        """``f(q, qd, tau) -> qdd`` for one state (arrays of length n_joints).

        Parameters
        ----------
        params : dict or array_like, optional
        coulomb_smoothing : float [rad/s]
            0: exact sign(q̇) in Coulomb terms; > 0: tanh(q̇ / coulomb_smoothing), which an ODE
            integrator needs to step through velocity reversals in reasonable time.

        Returns
        -------
        callable
        """
        self.check_simulable(params)
        beta = self.parameter_vector(params)
        k = self._c_kernel()
        n = self.n_joints
        eps = float(coulomb_smoothing)
        if k is not None:
            return k.forward_one(beta, eps)
        chain = self._chain
        motor_eps = self._motor_coulomb_smoothing(beta, eps)
        core = self._core_kernel()
        if core is not None and chain.transmission is not None:
            parts = core.mass_and_bias(beta, eps)  # C for the bodies, the motors in numpy
            tr, motor = chain.transmission, chain.motor_values(beta)
            M_motor = tr.mass(motor)

            def rhs_mixed(q, qd, tau):
                M, h = parts(q, qd)
                qd1 = np.reshape(qd, (1, n))
                h = h + tr.torque(motor, qd1, np.zeros((1, n)), motor_eps)[0]
                return np.linalg.solve(M + M_motor, np.asarray(tau, dtype=float) - h)

            return rhs_mixed

        def rhs_np(q, qd, tau):
            q1, qd1 = np.reshape(q, (1, n)), np.reshape(qd, (1, n))
            M = rigid.mass_matrix(chain, beta, q1)[0]
            h = rigid.rnea(
                chain, beta, q1, qd1, np.zeros((1, n)), smoothing=eps, motor_smoothing=motor_eps
            )[0]
            return np.linalg.solve(M, np.asarray(tau, dtype=float) - h)

        return rhs_np

    def _motor_coulomb_smoothing(self, beta, eps: float) -> float:
        """The smoothing [rad/s, motor side] of the motor-side Coulomb terms in simulation.

        The event-driven exact Coulomb simulation (`physid.simulate.coulomb`) freezes the
        joints' own Coulomb torques; a motor's Coulomb torque on θ̇m = K q̇ is not one joint's,
        and sign(θ̇m) would stall an ODE integrator at each reversal. With ``eps`` = 0 such
        terms use tanh(θ̇m / `MOTOR_COULOMB_SMOOTHING`) (a band of 1 rad/s at the motor, a few
        hundredths of a rad/s at the joint through a gear), and a note says so.
        """
        tr = self._chain.transmission
        if eps > 0 or tr is None:
            return eps
        values = self._chain.motor_values(beta)
        used = [t[2] for t, v in zip(tr.terms, values, strict=True) if t[1] == "coulomb" and v]
        if not used:
            return eps
        import warnings

        from .urdf import ModelWarning

        warnings.warn(
            f"simulating {self.name!r}: the motor-side Coulomb terms {used} use "
            f"tanh(θ̇m / {MOTOR_COULOMB_SMOOTHING:g} rad/s) instead of sign(θ̇m) (the exact "
            "Coulomb simulation freezes the joints' own friction only).",
            ModelWarning,
            stacklevel=3,
        )
        return MOTOR_COULOMB_SMOOTHING

    def make_state_rhs(self, params=None):
        """``f(y, tau) -> ẏ`` for the state y = [q, q̇] (length 2·n_joints).

        Parameters
        ----------
        params : dict or array_like, optional

        Returns
        -------
        callable
        """
        f = self.make_rhs(params)
        n = self.n_joints

        def state_rhs(y, tau):
            y = np.asarray(y, dtype=float)
            return np.concatenate([y[n:], f(y[:n], y[n:], tau)]).tolist()

        return state_rhs

    def symbolic_equations(self):
        """Not available: rigid-body models are evaluated numerically (Newton–Euler).

        Returns
        -------
        None
            Never; raises.

        Raises
        ------
        InputError
            Always.
        """
        raise InputError(
            f"model {self.name!r} is a rigid-body model evaluated by Newton–Euler; it has no "
            "symbolic equations. Use inverse_dynamics, mass_matrix or regressor."
        )
