"""Serial manipulators built from homogeneous transforms: equations of motion as fast numeric code.

A chain of n revolute joints. Link k's frame is ``T_1(q_1) ⋯ T_k(q_k)`` in the base frame, with
``T_k`` a Denavit–Hartenberg transform Rz(q_k + offset) Tz(d) Tx(a) Rx(α) or an explicit 4 × 4
matrix of expressions in q_k and the parameters. A point mass m_k sits at the origin of frame k
(Cedro & Janecki put the mass at the end of each link), an optional rotor/link inertia J_k adds
½ J_k q̇_k² (the paper's K0[k], J_k = m_k l_k²/12), gravity is an explicit vector g in the base
frame with V = −Σ m_k g·p_k, and friction is viscous·q̇ + coulomb·sign(q̇) per joint.

The equations (see `physid.models.lagrange`) are derived once with sympy, turned into
common-subexpression-eliminated Python source (`physid.models.codegen`) and cached on disk by a
hash of the model's content; `ChainModel` wraps the generated functions with input validation.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from .._validate import as_2d, check_finite, parameter_vector
from ..errors import IdentifiabilityError, InputError, ModelFileError, ShapeError
from . import _cache
from .chain_base import BaseParameters, _format_combination  # noqa: F401 - re-exported
from .chain_derive import (  # noqa: F401 - re-exported
    _derive,
    _derive_jacobian,
    _derive_regressor,
    _scalar_factory_source,
    _scalar_sources,
    _valid_entry,
    _with_progress,
    on_symbolic_chain,
)
from .chain_regressor import _LinearInParameters
from .codegen import source_to_function
from .spec_types import ChainSpec

__all__ = ["ChainModel", "BaseParameters", "build_chain_model", "MAX_SYMBOLIC_JOINTS"]

#: The most joints of a symbolic (point-mass, Denavit-Hartenberg) chain: its Lagrange
#: derivation's expressions grow like a high power of the joint count (measured on one core:
#: 4 joints 4 s, 5 joints 15 s, 6 joints 110 s), so a longer chain is refused at once
#: instead of running for hours. Rigid-body models (URDF, or a TOML file with full link
#: inertias) are built numerically and have no such limit.
MAX_SYMBOLIC_JOINTS = 6


def _check_symbolic_size(spec: ChainSpec) -> None:
    """Refuse a symbolic chain longer than `MAX_SYMBOLIC_JOINTS`, naming the limit and why."""
    n = len(spec.joints)
    if n <= MAX_SYMBOLIC_JOINTS:
        return
    where = f"{spec.source}: " if getattr(spec, "source", None) else ""
    raise ModelFileError(
        f"{where}the chain {spec.name!r} has {n} joints; symbolic chain models (kind = "
        f'"chain", point masses on Denavit-Hartenberg links) are limited to '
        f"{MAX_SYMBOLIC_JOINTS} joints, because their symbolic Lagrange derivation grows like "
        "a high power of the joint count (5 joints take about 15 s, 6 about 2 min, and each "
        "further joint several times longer). Describe a longer arm as a URDF file or as a rigid-body "
        "TOML model with link inertias (docs/model-files.md), which are built numerically."
    )


def build_chain_model(
    spec: ChainSpec, *, kinetic: str | None = None, cache: bool = True
) -> ChainModel:
    """Derive (or load from the cache) the numeric functions of a chain spec.

    Parameters
    ----------
    spec : ChainSpec
        The model description (from a TOML file or `physid.models.library`).
    kinetic : {"exact", "paper"}, optional
        Override the spec's kinetic-energy mode.
    cache : bool
        Read and write the on-disk cache (default True).

    Returns
    -------
    ChainModel
        The frozen model with its generated numeric functions.
    """
    if kinetic is not None:
        if kinetic not in ("exact", "paper"):
            raise InputError(f"kinetic must be 'exact' or 'paper'; got {kinetic!r}.")
        spec = replace(spec, kinetic=kinetic)
    if not isinstance(cache, bool):
        raise InputError(f"cache must be True or False; got {cache!r}.")
    _check_symbolic_size(spec)
    key = _cache.content_key(spec.derivation_content())
    start = time.perf_counter()
    data, from_cache = _cache.cached(
        "chain",
        key,
        lambda: _with_progress(spec, lambda: _derive(spec)),
        enabled=cache,
        valid=lambda d: _valid_entry(d, spec),
    )
    model = ChainModel(spec, data, key=key, from_cache=from_cache, cache=cache)
    model.load_seconds = time.perf_counter() - start
    return model


# ---------------------------------------------------------------------------------------------
# the model
# ---------------------------------------------------------------------------------------------


class ChainModel(_LinearInParameters):
    """Equations of motion of a serial manipulator as vectorised numeric functions.

    Build with `physid.load_model` (``"manipulator"`` or a TOML file) or `build_chain_model`.

    All dynamics functions take arrays of shape ``(n_samples, n_joints)`` — joint angles q [rad],
    rates q̇ [rad/s], accelerations q̈ [rad/s²], torques τ [N·m] — and ``params``: None (nominal
    values), a dict of overrides ``{"m2": 24.0}`` or an array ordered like `parameter_names`.
    No Python loop over samples: each call is a fixed number of numpy operations on columns.

    Attributes
    ----------
    name : str
    n_joints : int
    parameter_names : tuple of str
        θ in model order (for the paper's arm: m1, m2, m3, m4, l1, l2, l3, l4).
    parameters : dict
        Nominal values, name → value (SI units); a fresh copy on every access.
    units : dict
        name → unit string.
    unknown : tuple of str
        Parameters marked ``identify = true`` (estimated by default).
    kinetic : {"exact", "paper"}
    gravity : tuple of 3 float
        Gravity vector [m/s²] in the base frame (V = −Σ m_k g·p_k).
    loaded_from_cache : bool
        True when the generated code came from the on-disk cache (no sympy work).
    cache_key : str
        Hash of the model content that keys the cache.
    load_seconds : float
        Wall time of the derivation or cache load [s].
    """

    def __init__(
        self,
        spec: ChainSpec,
        data: dict,
        *,
        key: str = "",
        from_cache: bool = False,
        cache: bool = True,
    ):
        self._spec = spec
        self._data = data
        self._cache_enabled = cache
        self.name = spec.name
        self.n_joints = int(data["n_joints"])
        self.parameter_names = tuple(spec.parameter_names)
        self._nominal = np.array([p.value for p in spec.parameters], dtype=float)
        self.units = {p.name: p.unit for p in spec.parameters}
        self.unknown = tuple(p.name for p in spec.parameters if p.identify)
        self.kinetic = spec.kinetic
        self.gravity = tuple(spec.gravity)
        self.joint_names = tuple(j.name for j in spec.joints)
        self.loaded_from_cache = from_cache
        self.cache_key = key
        self.load_seconds = float("nan")
        src = data["sources"]
        self._f_tau = source_to_function(src["tau"], "tau")
        self._f_mass = source_to_function(src["mass"], "mass")
        self._f_bias = source_to_function(src["bias"], "bias")
        self._f_gravity = source_to_function(src["gravity"], "gravity")
        self._f_jacobian = None  # symbolic ∂τ/∂θ, only for models not polynomial in θ
        self._scalar_code = (data["scalar_const"], data["scalar_body"], data["zero_lower"])
        self._factories: dict = {}
        scal = _scalar_sources(self.n_joints, len(self.parameter_names), *self._scalar_code)
        self._scalar = {
            name: source_to_function(text, f"make_{name}", scalar=True)
            for name, text in scal.items()
        }
        n = self.n_joints
        self._lower = [(i, j) for i in range(n) for j in range(i + 1)]
        self._regressor = None

    # -- description --------------------------------------------------------------------------
    @property
    def parameters(self) -> dict:
        """Nominal parameter values, name → value in SI units (a fresh dict on every access)."""
        return dict(zip(self.parameter_names, self._nominal.tolist(), strict=False))

    @property
    def spec(self) -> ChainSpec:
        """The model specification this model was built from."""
        return self._spec

    def _repr_html_(self) -> str:
        """A notebook summary: joints (or input → output) and the nominal parameters."""
        from ._display import model_html

        return model_html(self)

    def __repr__(self) -> str:
        return (
            f"ChainModel(name={self.name!r}, n_joints={self.n_joints}, kinetic={self.kinetic!r}, "
            f"parameters={self.parameters})"
        )

    # -- argument handling --------------------------------------------------------------------
    def parameter_vector(self, params=None) -> np.ndarray:
        """θ ordered like `parameter_names`: nominal values overridden by ``params``.

        Parameters
        ----------
        params : dict or array_like (n_parameters,), optional
            None: nominal values; a dict overrides some (``{"m2": 24.0}``); an array gives all,
            ordered like `parameter_names` (SI units).

        Returns
        -------
        ndarray, shape (n_parameters,) [SI units of each parameter]
            A new array.

        Raises
        ------
        InputError
            Unknown names or non-finite values.
        ShapeError
            An array of the wrong length.
        """
        return parameter_vector(params, self.parameter_names, self._nominal, model=self.name)

    def _states(self, *pairs):
        n_j = self.n_joints
        arrays = []
        for x, name in pairs:
            arr = as_2d(x, name, n_channels=n_j)
            check_finite(arr, name)
            arrays.append(arr)
        n = arrays[0].shape[0]
        for arr, (_, name) in zip(arrays[1:], pairs[1:], strict=False):
            if arr.shape[0] != n:
                raise ShapeError(
                    f"{name} has {arr.shape[0]} samples but {pairs[0][1]} has {n}; pass arrays of "
                    f"equal length (n_samples, {n_j})."
                )
        return n, [tuple(np.ascontiguousarray(a.T)) for a in arrays]

    # -- dynamics -----------------------------------------------------------------------------
    def inverse_dynamics(self, q, qd, qdd, params=None) -> np.ndarray:
        """Joint torques τ = M(q) q̈ + c(q, q̇) + G(q) + F(q̇) [N·m], shape (n_samples, n_joints).

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n_samples, n_joints)
            Joint angles [rad], rates [rad/s] and accelerations [rad/s²] (a 1-D array is one
            joint's samples for a one-joint model).
        params : dict or array_like (n_parameters,), optional
            None: nominal values; a dict overrides some (``{"m2": 24.0}``); an array gives all,
            ordered like `parameter_names` (SI units).

        Returns
        -------
        ndarray, shape (n_samples, n_joints) [N·m]
            Joint torques τ(q, q̇, q̈, θ) (Lagrange's equations; friction included).

        Examples
        --------
        At rest the torque is the gravity torque:

        >>> import numpy as np, physid
        >>> model = physid.load_model("manipulator")
        >>> q = np.array([[0.1, 0.5, -0.3, 0.2]]); zero = np.zeros((1, 4))
        >>> bool(np.allclose(model.inverse_dynamics(q, zero, zero), model.gravity_forces(q)))
        True
        """
        n, cols = self._states((q, "q"), (qd, "qd"), (qdd, "qdd"))
        th = self.parameter_vector(params).tolist()
        return np.ascontiguousarray(self._f_tau(*cols, th, n).T)

    def mass_matrix(self, q, params=None) -> np.ndarray:
        """Mass (inertia) matrix M(q) [kg·m²], shape (n_samples, n_joints, n_joints), symmetric.

        Parameters
        ----------
        q : array_like, shape (n_samples, n_joints) [rad]
            Joint angles.
        params : dict or array_like (n_parameters,), optional
            None: nominal values; a dict overrides some (``{"m2": 24.0}``); an array gives all,
            ordered like `parameter_names` (SI units).

        Returns
        -------
        ndarray, shape (n_samples, n_joints, n_joints) [kg·m²]
            M(q) with T = ½ q̇ᵀ M(q) q̇ (``kinetic="paper"``: the paper's diagonal form).

        Examples
        --------
        >>> import numpy as np, physid
        >>> M = physid.load_model("manipulator").mass_matrix([[0.1, 0.5, -0.3, 0.2]])
        >>> M.shape, bool(np.allclose(M, M.transpose(0, 2, 1)))
        ((1, 4, 4), True)
        """
        n, (Q,) = self._states((q, "q"))
        th = self.parameter_vector(params).tolist()
        return self._assemble_mass(self._f_mass(Q, th, n), n)

    def _assemble_mass(self, lower, n):
        nj = self.n_joints
        M = np.empty((n, nj, nj))
        for r, (i, j) in enumerate(self._lower):
            M[:, i, j] = lower[r]
            M[:, j, i] = lower[r]
        return M

    def bias_forces(self, q, qd, params=None) -> np.ndarray:
        """h = c(q, q̇) + G(q) + F(q̇) [N·m]: the torque at q̈ = 0, shape (n_samples, n_joints).

        Parameters
        ----------
        q, qd : array_like, shape (n_samples, n_joints)
            Joint angles [rad] and rates [rad/s].
        params : dict or array_like (n_parameters,), optional
            None: nominal values; a dict overrides some (``{"m2": 24.0}``); an array gives all,
            ordered like `parameter_names` (SI units).

        Returns
        -------
        ndarray, shape (n_samples, n_joints) [N·m]
            Coriolis/centrifugal, gravity and friction torques, so that τ = M(q) q̈ + h.
        """
        n, cols = self._states((q, "q"), (qd, "qd"))
        th = self.parameter_vector(params).tolist()
        return np.ascontiguousarray(self._f_bias(*cols, th, n).T)

    def gravity_forces(self, q, params=None) -> np.ndarray:
        """G(q) = ∂V/∂q [N·m], the torque holding the arm still; shape (n_samples, n_joints).

        Parameters
        ----------
        q : array_like, shape (n_samples, n_joints) [rad]
            Joint angles.
        params : dict or array_like (n_parameters,), optional
            None: nominal values; a dict overrides some (``{"m2": 24.0}``); an array gives all,
            ordered like `parameter_names` (SI units).

        Returns
        -------
        ndarray, shape (n_samples, n_joints) [N·m]
            G(q) with V = −Σ m_k g·p_k (g the model's `gravity` vector).
        """
        n, cols = self._states((q, "q"))
        th = self.parameter_vector(params).tolist()
        return np.ascontiguousarray(self._f_gravity(*cols, th, n).T)

    def forward_dynamics(self, q, qd, tau, params=None) -> np.ndarray:
        """Joint accelerations q̈ = M(q)⁻¹ (τ − h(q, q̇)) [rad/s²], shape (n_samples, n_joints).

        One batched ``numpy.linalg.solve`` over all samples (no explicit inverse).

        Parameters
        ----------
        q, qd : array_like, shape (n_samples, n_joints)
            Joint angles [rad] and rates [rad/s].
        tau : array_like, shape (n_samples, n_joints) [N·m]
            Joint torques.
        params : dict or array_like (n_parameters,), optional
            None: nominal values; a dict overrides some (``{"m2": 24.0}``); an array gives all,
            ordered like `parameter_names` (SI units).

        Returns
        -------
        ndarray, shape (n_samples, n_joints) [rad/s²]

        Raises
        ------
        InputError
            M(q) is singular at some sample (a joint that moves no mass).

        Examples
        --------
        Forward dynamics inverts inverse dynamics:

        >>> import numpy as np, physid
        >>> model = physid.load_model("manipulator")
        >>> rng = np.random.default_rng(0)
        >>> q, qd, qdd = rng.normal(size=(3, 5, 4))
        >>> tau = model.inverse_dynamics(q, qd, qdd)
        >>> bool(np.allclose(model.forward_dynamics(q, qd, tau), qdd))
        True
        """
        n, (Q, QD, TAU) = self._states((q, "q"), (qd, "qd"), (tau, "tau"))
        th = self.parameter_vector(params).tolist()
        M = self._assemble_mass(self._f_mass(Q, th, n), n)
        rhs = np.array(TAU).T - self._f_bias(Q, QD, th, n).T
        try:
            return np.linalg.solve(M, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:
            cond = np.linalg.cond(M)
            i = int(np.argmax(~np.isfinite(cond) | (cond > 1e15)))
            raise InputError(
                f"the mass matrix is singular at sample {i} (condition number {cond[i]:.3g}): some "
                f"joint moves no mass there (e.g. a point mass on its axis). Give that joint a "
                f"rotor_inertia in the model, or avoid the configuration."
            ) from None

    def parameter_jacobian(self, q, qd, qdd, params=None) -> np.ndarray:
        """∂τ/∂θ (analytic), shape (n_samples, n_joints, n_parameters), θ like `parameter_names`.

        Computed as Y(q, q̇, q̈) · ∂β/∂θ from the linear-in-parameters form (exact: τ = Y β(θ)
        with β polynomial in θ); for models not polynomial in θ, from symbolically
        differentiated code. Tip for repeated calls on the same data (an input-error fit): compute
        ``Y = regressor(q, qd, qdd)`` once, then τ = Y @ beta(θ) and ∂τ/∂θ = Y @ beta_jacobian(θ).

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n_samples, n_joints)
            Joint angles [rad], rates [rad/s] and accelerations [rad/s²].
        params : dict or array_like (n_parameters,), optional
            None: nominal values; a dict overrides some (``{"m2": 24.0}``); an array gives all,
            ordered like `parameter_names` (SI units).

        Returns
        -------
        ndarray, shape (n_samples, n_joints, n_parameters) [N·m per unit of each parameter]
            Entry [i, k, j] = ∂τ_k/∂θ_j at sample i.

        Examples
        --------
        τ is linear in the masses, so ∂τ/∂m2 equals τ(m2 = 1) − τ(m2 = 0):

        >>> import numpy as np, physid
        >>> model = physid.load_model("manipulator")
        >>> q, qd, qdd = np.random.default_rng(1).normal(size=(3, 4, 4))
        >>> jac = model.parameter_jacobian(q, qd, qdd)
        >>> j = model.parameter_names.index("m2")
        >>> diff = (model.inverse_dynamics(q, qd, qdd, {"m2": 1.0})
        ...         - model.inverse_dynamics(q, qd, qdd, {"m2": 0.0}))
        >>> bool(np.allclose(jac[:, :, j], diff))
        True
        """
        n, cols = self._states((q, "q"), (qd, "qd"), (qdd, "qdd"))
        theta = self.parameter_vector(params)
        if self._polynomial():
            Y = self._regressor_eval(cols, n)  # (n, nj, n_beta)
            return Y @ self.beta_jacobian(theta)
        if self._f_jacobian is None:
            data, _ = _cache.cached(
                "jacobian",
                self.cache_key,
                lambda: _derive_jacobian(self._spec),
                enabled=self._cache_enabled,
                valid=lambda d: "source" in d,
            )
            self._f_jacobian = source_to_function(data["source"], "jacobian")
        out = self._f_jacobian(*cols, theta.tolist(), n)
        return out.reshape(self.n_joints, len(self.parameter_names), n).transpose(2, 0, 1).copy()

    def _polynomial(self) -> bool:
        try:
            self._regressor_data()
        except IdentifiabilityError:
            return False
        return True

    # -- fast single-state right-hand sides (for ODE integrators) ------------------------------
    def make_rhs(self, params=None):
        """Return ``f(q, qd, tau) -> qdd`` for ONE state (1-D arrays or lists of length n_joints).

        Generated scalar Python (no numpy calls inside) with an unrolled Cholesky solve of
        M q̈ = τ − h; parameters are bound once.

        Parameters
        ----------
        params : dict or array_like (n_parameters,), optional
            None: nominal values; a dict overrides some (``{"m2": 24.0}``); an array gives all,
            ordered like `parameter_names` (SI units).

        Returns
        -------
        callable
            ``f(q, qd, tau)`` with q [rad], q̇ [rad/s], τ [N·m] of length n_joints, returning
            q̈ [rad/s²] as an ndarray of shape (n_joints,).

        Examples
        --------
        Holding the arm with its gravity torque leaves it at rest:

        >>> import numpy as np, physid
        >>> model = physid.load_model("manipulator")
        >>> f = model.make_rhs()
        >>> q = [0.1, 0.5, -0.3, 0.2]
        >>> qdd = f(q, [0.0] * 4, model.gravity_forces([q])[0])
        >>> bool(np.allclose(qdd, 0.0, atol=1e-9))
        True
        """
        core = self._scalar["rhs"](self.parameter_vector(params).tolist())
        asarray = np.asarray

        def rhs(q, qd, tau):
            return asarray(
                core(
                    q.tolist() if hasattr(q, "tolist") else q,
                    qd.tolist() if hasattr(qd, "tolist") else qd,
                    tau.tolist() if hasattr(tau, "tolist") else tau,
                )
            )

        return rhs

    def make_state_rhs(self, params=None):
        """Return ``f(y, tau) -> ẏ`` for the state y = [q, q̇] (length 2·n_joints).

        ẏ = [q̇, M⁻¹(τ − h)] as a Python list of floats (``scipy.integrate.solve_ivp`` accepts it);
        ``y`` may be a numpy array or a list, ``tau`` a sequence of n_joints torques [N·m].

        Parameters
        ----------
        params : dict or array_like (n_parameters,), optional
            As in `parameter_vector`; bound once.

        Returns
        -------
        callable
            ``f(y, tau)`` with y = [q [rad], q̇ [rad/s]] of length 2·n_joints and τ [N·m] of
            length n_joints, returning [q̇ [rad/s], q̈ [rad/s²]] as a list of 2·n_joints floats.
        """
        core = self._scalar["state"](self.parameter_vector(params).tolist())

        def state_rhs(y, tau):
            return core(
                y.tolist() if hasattr(y, "tolist") else y,
                tau.tolist() if hasattr(tau, "tolist") else tau,
            )

        return state_rhs

    def scalar_factory(
        self,
        name: str,
        *,
        outer_args: str,
        outer_extra: Sequence[str] = (),
        inner_args: str,
        prologue: Sequence[str],
        ret: str,
    ):
        """Generated factory of a fused single-state right-hand side with a torque law of its own.

        The hook through which a later stage fuses a control law into the generated dynamics
        (`physid.simulate.pd.pd_rhs` does, for the PD law) without the model knowing the law. The
        factory is ``make_<name>(TH, ...)`` with ``TH`` the parameter vector and `outer_args`
        after it; it returns ``<name>(<inner_args>)``, whose body is `prologue`, then the
        generated dynamics, then `ret`. Names the lines may use: ``_q<i>``, ``_qd<i>`` (the
        prologue binds them), ``T<i>`` (the torques, bound by the prologue), ``X<i>`` (q̈, bound by
        the dynamics). Compiled once per model and name.

        Parameters
        ----------
        name : str
            Python identifier of the inner function (the cache key, with the code).
        outer_args : str
            Arguments of the factory, starting with ``TH``.
        outer_extra : sequence of str
            Lines run once in the factory (e.g. unpacking gains).
        inner_args : str
            Arguments of the inner function.
        prologue : sequence of str
            Lines run first on every call; they bind ``_q<i>``, ``_qd<i>`` and ``T<i>``.
        ret : str
            The inner function's return statement.

        Returns
        -------
        callable
            The factory ``make_<name>``.
        """
        key = (name, outer_args, tuple(outer_extra), inner_args, tuple(prologue), ret)
        factory = self._factories.get(key)
        if factory is None:
            text = _scalar_factory_source(
                self.n_joints,
                len(self.parameter_names),
                *self._scalar_code,
                name,
                outer_args,
                list(outer_extra),
                inner_args,
                list(prologue),
                ret,
            )
            factory = source_to_function(text, f"make_{name}", scalar=True)
            self._factories[key] = factory
        return factory

    # -- symbolic view ------------------------------------------------------------------------
    def symbolic_equations(self):
        """Re-derive the equations with readable sympy symbols (q1, qd1, qdd1, m1, ...).

        Returns a `physid.models.lagrange.ChainEquations`. Slow (sympy); not cached.
        """
        import sympy as sp

        from .chain_symbolic import symbolic_chain
        from .lagrange import ChainEquations, derive_chain_equations

        sym = symbolic_chain(self._spec)
        eqs = on_symbolic_chain(derive_chain_equations, self._spec, sym)
        n = self.n_joints
        rename = {}
        for i in range(n):
            rename[sym["q"][i]] = sp.Symbol(f"q{i + 1}", real=True)
            rename[sym["qd"][i]] = sp.Symbol(f"qd{i + 1}", real=True)
            rename[sym["qdd"][i]] = sp.Symbol(f"qdd{i + 1}", real=True)
        for s, name in zip(sym["theta"], self.parameter_names, strict=False):
            rename[s] = sp.Symbol(name, real=True)

        def rn(e):
            return sp.sympify(e, strict=True).xreplace(rename)

        return ChainEquations(
            q=tuple(rename[s] for s in sym["q"]),
            qd=tuple(rename[s] for s in sym["qd"]),
            qdd=tuple(rename[s] for s in sym["qdd"]),
            theta=tuple(rename[s] for s in sym["theta"]),
            mass_matrix=eqs.mass_matrix.xreplace(rename),
            coriolis=tuple(rn(e) for e in eqs.coriolis),
            gravity=tuple(rn(e) for e in eqs.gravity),
            friction=tuple(rn(e) for e in eqs.friction),
            positions=tuple(p.xreplace(rename) for p in eqs.positions),
        )
