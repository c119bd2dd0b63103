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

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from .._validate import as_2d, check_finite, parameter_vector
from ..errors import IdentifiabilityError, InputError, ShapeError
from . import _cache
from .codegen import cholesky_solve_lines, source_to_function
from .spec import ChainSpec

__all__ = ["ChainModel", "BaseParameters", "build_chain_model"]


# ---------------------------------------------------------------------------------------------
# derivation (cold path: sympy)
# ---------------------------------------------------------------------------------------------


def _derive(spec: ChainSpec) -> dict:
    """Derive the equations of `spec` and generate the source of every numeric function.

    One common-subexpression elimination over [M (lower triangle), c, G, F] feeds every
    generated function: mass, gravity, bias (c + G + F), inverse dynamics (Σ_j M_ij q̈_j + h_i,
    assembled in the generated code rather than as one huge expression) and the scalar body of
    the single-state right-hand sides.
    """
    import sympy as sp

    from .codegen import SharedExpressions
    from .lagrange import derive_chain_equations
    from .spec import symbolic_chain

    sym = symbolic_chain(spec)
    q, qd, qdd, th = sym["q"], sym["qd"], sym["qdd"], sym["theta"]
    n = len(q)
    eqs = derive_chain_equations(
        sym["transforms"],
        sym["masses"],
        sym["rotor_inertias"],
        sym["viscous"],
        sym["coulomb"],
        spec.gravity,
        q,
        qd,
        qdd,
        th,
        kinetic=spec.kinetic,
        axis_static=sym["axis_static"],
    )
    M = eqs.mass_matrix
    lower = [(i, j) for i in range(n) for j in range(i + 1)]
    zero_lower = [[i, j] for i, j in lower if M[i, j] == 0]
    nl = len(lower)
    shared = SharedExpressions(
        [M[i, j] for i, j in lower] + list(eqs.coriolis) + list(eqs.gravity) + list(eqs.friction),
        angles=q,
    )
    red = shared.reduced
    Mr = {pair: red[r] for r, pair in enumerate(lower)}
    Cr = red[nl : nl + n]
    Gr = red[nl + n : nl + 2 * n]
    Fr = red[nl + 2 * n : nl + 3 * n]

    def m_entry(i, j):
        return Mr[(i, j)] if i >= j else Mr[(j, i)]

    hr = [Cr[i] + Gr[i] + Fr[i] for i in range(n)]
    taur = [sp.Add(*[m_entry(i, j) * qdd[j] for j in range(n)], hr[i]) for i in range(n)]
    sources = {
        "tau": shared.vector_function(
            "tau", [("Q", q), ("QD", qd), ("QDD", qdd), ("TH", th)], taur
        ),
        "mass": shared.vector_function("mass", [("Q", q), ("TH", th)], [Mr[p] for p in lower]),
        "bias": shared.vector_function("bias", [("Q", q), ("QD", qd), ("TH", th)], hr),
        "gravity": shared.vector_function("gravity", [("Q", q), ("TH", th)], Gr),
    }
    # scalar body: M_ij (lower, non-zero) and H_i = c + G + F, shared by all fused right-hand sides
    assignments = [(f"M{i}_{j}", Mr[(i, j)]) for i, j in lower if M[i, j] != 0]
    assignments += [(f"H{i}", hr[i]) for i in range(n)]
    head, body = shared.scalar_lines_split(assignments, th)
    return {
        "n_joints": n,
        "parameter_names": list(spec.parameter_names),
        "kinetic": spec.kinetic,
        "zero_lower": zero_lower,
        "sources": sources,
        "scalar_const": head,
        "scalar_body": body,
    }


def _derive_jacobian(spec: ChainSpec) -> dict:
    """∂τ/∂θ by symbolic differentiation (fallback for models not polynomial in θ; slow)."""
    from .codegen import vector_function_source
    from .lagrange import derive_chain_equations
    from .spec import symbolic_chain

    sym = symbolic_chain(spec)
    q, qd, qdd, th = sym["q"], sym["qd"], sym["qdd"], sym["theta"]
    eqs = derive_chain_equations(
        sym["transforms"],
        sym["masses"],
        sym["rotor_inertias"],
        sym["viscous"],
        sym["coulomb"],
        spec.gravity,
        q,
        qd,
        qdd,
        th,
        kinetic=spec.kinetic,
        axis_static=sym["axis_static"],
    )
    tau = eqs.tau
    outputs = [tau[i].diff(t) for i in range(len(q)) for t in th]
    src = vector_function_source(
        "jacobian", [("Q", q), ("QD", qd), ("QDD", qdd), ("TH", th)], outputs
    )
    return {"source": src}


def _scalar_factory_source(
    n: int,
    n_params: int,
    const: list[str],
    body: list[str],
    zero_lower,
    name: str,
    outer_args: str,
    outer_extra: list[str],
    inner_args: str,
    prologue: list[str],
    ret: str,
) -> str:
    """Source of ``make_<name>(<outer_args>)``: a factory of one single-state right-hand side.

    The factory evaluates the parameter-only lines once and returns an inner function whose free
    variables are closure cells (as fast as locals). The inner function runs `prologue` (which must
    bind ``_q<i>``, ``_qd<i>`` and the torques ``T<i>``), the dynamics ``M q̈ = τ − h`` (Cholesky,
    solution ``X<i>``) and `ret`.
    """
    zero = {tuple(z) for z in zero_lower}
    th = (", ".join(f"_th{i}" for i in range(n_params)) + ", = TH") if n_params else "pass"
    solve = [f"B{i} = T{i} - H{i}" for i in range(n)]  # M q̈ = τ − h
    solve += cholesky_solve_lines(n, "M", "B", "X", zero)
    lines = [f"def make_{name}({outer_args}):", f"    {th}"]
    lines += ["    " + line for line in outer_extra + const]
    lines += [f"    def {name}({inner_args}):"]
    lines += ["        " + line for line in prologue + body + solve + [ret]]
    lines += [f"    return {name}"]
    return "\n".join(lines) + "\n"


def _scalar_sources(n: int, n_params: int, const: list[str], body: list[str], zero_lower) -> dict:
    """The factories of the open-loop single-state right-hand sides (``rhs``, ``state``)."""
    q = ", ".join(f"_q{i}" for i in range(n))
    qd = ", ".join(f"_qd{i}" for i in range(n))
    qdd_list = ", ".join(f"X{i}" for i in range(n))
    qd_list = ", ".join(f"_qd{i}" for i in range(n))
    taus = ", ".join(f"T{i}" for i in range(n))

    def make(name, outer_args, outer_extra, inner_args, prologue, ret):
        return _scalar_factory_source(
            n,
            n_params,
            const,
            body,
            zero_lower,
            name,
            outer_args,
            outer_extra,
            inner_args,
            prologue,
            ret,
        )

    return {
        "rhs": make(
            "rhs",
            "TH",
            [],
            "Q, QD, TAU",
            [f"{q}, = Q", f"{qd}, = QD", f"{taus}, = TAU"],
            f"return [{qdd_list}]",
        ),
        "state": make(
            "state",
            "TH",
            [],
            "Y, TAU",
            [f"{q}, {qd}, = Y", f"{taus}, = TAU"],
            f"return [{qd_list}, {qdd_list}]",
        ),
    }


def _derive_regressor(spec: ChainSpec) -> dict:
    """Linear-in-parameters form τ = Y(q, q̇, q̈) β(θ): monomials and the source of Y."""
    import sympy as sp

    from .codegen import vector_function_source
    from .lagrange import monomial_name, regressor_columns
    from .spec import symbolic_chain

    sym = symbolic_chain(spec)
    q, qd, qdd, th = sym["q"], sym["qd"], sym["qdd"], sym["theta"]
    n = len(q)
    try:
        monomials, columns = regressor_columns(
            sym["transforms"],
            sym["masses"],
            sym["rotor_inertias"],
            sym["viscous"],
            sym["coulomb"],
            spec.gravity,
            q,
            qd,
            qdd,
            th,
            kinetic=spec.kinetic,
            axis_static=sym["axis_static"],
        )
    except sp.PolynomialError as exc:
        raise IdentifiabilityError(
            f"model {spec.name!r} is not polynomial in its parameters ({exc}), so it has no "
            f"linear-in-parameters form τ = Y β(θ); use parameter_jacobian() instead."
        ) from None
    outputs = [columns[b][i] for i in range(n) for b in range(len(monomials))]
    source = vector_function_source("regressor", [("Q", q), ("QD", qd), ("QDD", qdd)], outputs)
    names = [monomial_name(m, spec.parameter_names) for m in monomials]
    # drop columns that vanish identically (cancellations sympy missed), checked at random states
    f = source_to_function(source, "regressor")
    rng = np.random.default_rng(20240601)
    ns = 64
    args = [
        tuple(rng.uniform(-np.pi, np.pi, (n, ns))),
        tuple(rng.normal(size=(n, ns))),
        tuple(rng.normal(size=(n, ns))),
    ]
    Y = f(*args, ns).reshape(n, len(monomials), ns)
    norms = np.sqrt((Y**2).sum(axis=(0, 2)))
    scale = norms.max() if norms.size else 1.0
    keep = [b for b in range(len(monomials)) if norms[b] > 1e-11 * scale]
    return {
        "monomials": [list(m) for m in monomials],
        "names": names,
        "keep": keep,
        "source": source,
    }


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


def _with_progress(spec: ChainSpec, work, *, after: float = 1.0, what: str = "equations of motion"):
    """Run a derivation; when it takes longer than ``after`` seconds, say so on stderr.

    A cold derivation of a 6-joint chain takes seconds, a 10-joint one minutes: without a word a
    user cannot tell a slow derivation from a hang. Nothing is printed for quick ones.
    """
    import sys
    import threading

    start = time.perf_counter()
    said = threading.Event()

    def announce():
        said.set()
        print(
            f"physid: deriving the {what} of {spec.name!r} ({len(spec.joints)} joints, "
            "symbolic Lagrange); this is done once and cached ...",
            file=sys.stderr,
            flush=True,
        )

    timer = threading.Timer(after, announce)
    timer.daemon = True
    timer.start()
    try:
        return work()
    finally:
        timer.cancel()
        if said.is_set():
            print(
                f"physid: derived the {what} of {spec.name!r} in "
                f"{time.perf_counter() - start:.1f} s",
                file=sys.stderr,
                flush=True,
            )


def _valid_entry(data: dict, spec: ChainSpec) -> bool:
    try:
        return (
            data["n_joints"] == len(spec.joints)
            and data["parameter_names"] == list(spec.parameter_names)
            and set(data["sources"]) >= {"tau", "mass", "bias", "gravity"}
            and isinstance(data["scalar_body"], list)
            and isinstance(data["scalar_const"], list)
        )
    except (KeyError, TypeError):
        return False


# ---------------------------------------------------------------------------------------------
# base parameters
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BaseParameters:
    """Which combinations of the parameters the equations of motion can determine.

    τ = Y(q, q̇, q̈) β(θ); the columns of Y are linearly dependent, so only ``n_base``
    combinations ``base = K β`` are identifiable (found by QR with column pivoting on Y at random
    states). On top of that, ``theta_rank`` says how many directions of θ itself the base
    parameters pin down at the nominal θ (rank of ∂base/∂θ).

    Attributes
    ----------
    beta_names : tuple of str
        Monomials β of the parameters, e.g. ``"m2*l2**2"``.
    n_beta, n_base : int
        Number of monomials and of base parameters (identifiable combinations).
    base_names : tuple of str
        Each base parameter written as a combination of monomials.
    base_matrix : ndarray (n_base, n_beta)
        K in base = K β.
    independent : tuple of str
        The monomials chosen as the leading term of each base parameter.
    no_effect : tuple of str
        Monomials that appear in the energies but cancel out of τ.
    parameter_names : tuple of str
        θ, in model order.
    theta_rank : int
        Rank of ∂base/∂θ at the nominal parameters (≤ len(parameter_names)).
    unidentifiable : tuple of str
        Plain-language statements, e.g. "m1 and l1 enter only as m1*l1**2: only that product can
        be identified".
    null_directions : ndarray (n_theta, n_theta - theta_rank)
        Relative changes dθ/θ that leave every base parameter unchanged (to first order).
    combinations : tuple of Combination
        The same statements as `physid.models.identifiability.Combination` objects (the one way
        physid names unidentifiable combinations; ``unidentifiable`` holds their texts).
    """

    beta_names: tuple
    n_beta: int
    n_base: int
    base_names: tuple
    base_matrix: np.ndarray
    independent: tuple
    no_effect: tuple
    parameter_names: tuple
    theta_rank: int
    unidentifiable: tuple
    null_directions: np.ndarray
    combinations: tuple = ()

    @property
    def expressions(self) -> tuple:
        """Each base parameter as a combination of the monomials (same as `base_names`)."""
        return self.base_names

    @property
    def description(self) -> str:
        """Human-readable summary (same as `summary`)."""
        return self.summary()

    def summary(self) -> str:
        """Multi-line text: the count, each base parameter, and what cannot be identified."""
        lines = [
            f"{self.n_base} base parameters (identifiable combinations) out of {self.n_beta} "
            f"monomials; θ-rank {self.theta_rank} of {len(self.parameter_names)} parameters.",
        ]
        lines += [f"  {name}" for name in self.base_names]
        if self.no_effect:
            lines.append(f"  no effect on τ: {', '.join(self.no_effect)}")
        lines += [f"  {s}" for s in self.unidentifiable]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """JSON-ready dictionary (arrays become nested lists)."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name == "combinations":
                v = [dataclasses.asdict(c) for c in v]
            out[f.name] = (
                v.tolist()
                if isinstance(v, np.ndarray)
                else (list(v) if isinstance(v, tuple) else v)
            )
        return out


def _format_combination(coeffs, names) -> str:
    terms = []
    for c, name in zip(coeffs, names, strict=False):
        if abs(c) < 1e-9:
            continue
        if abs(c - 1) < 1e-9:
            terms.append(f"+ {name}")
        elif abs(c + 1) < 1e-9:
            terms.append(f"- {name}")
        else:
            terms.append(f"{'-' if c < 0 else '+'} {abs(c):.6g}*{name}")
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else text


# ---------------------------------------------------------------------------------------------
# the model
# ---------------------------------------------------------------------------------------------


class ChainModel:
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

    # -- linear-in-parameters form ----------------------------------------------------------
    def _regressor_data(self) -> dict:
        if isinstance(self._regressor, IdentifiabilityError):
            raise self._regressor
        if self._regressor is None:
            try:
                data, _ = _cache.cached(
                    "regressor",
                    self.cache_key,
                    lambda: _with_progress(
                        self._spec,
                        lambda: _derive_regressor(self._spec),
                        what="regressor (linear-in-parameters form)",
                    ),
                    enabled=self._cache_enabled,
                    valid=lambda d: {"monomials", "names", "keep", "source"} <= set(d),
                )
            except IdentifiabilityError as exc:
                self._regressor = exc  # remembered: the derivation is not repeated
                raise
            data = dict(data)
            data["function"] = source_to_function(data["source"], "regressor")
            keep = data["keep"]
            data["exponents"] = np.array([data["monomials"][b] for b in keep], dtype=float).reshape(
                len(keep), len(self.parameter_names)
            )
            self._regressor = data
        return self._regressor

    @property
    def beta_names(self) -> tuple:
        """Names of the monomials β(θ) of the linear-in-parameters form, e.g. ``"m2*l2**2"``."""
        d = self._regressor_data()
        return tuple(d["names"][b] for b in d["keep"])

    def beta(self, params=None) -> np.ndarray:
        """β(θ): the monomial values, shape (n_beta,), so that τ = regressor(q, q̇, q̈) @ β.

        Parameters
        ----------
        params : dict or array_like (n_parameters,), optional
            As in `parameter_vector`.

        Returns
        -------
        ndarray, shape (n_beta,) [SI units of each monomial, e.g. kg·m² for ``m2*l2**2``]
        """
        theta = self.parameter_vector(params)
        E = self._regressor_data()["exponents"]
        return np.prod(theta[None, :] ** E, axis=1)

    def beta_jacobian(self, params=None) -> np.ndarray:
        """∂β/∂θ, shape (n_beta, n_parameters), at ``params`` (nominal by default).

        Parameters
        ----------
        params : dict or array_like (n_parameters,), optional
            As in `parameter_vector`.

        Returns
        -------
        ndarray, shape (n_beta, n_parameters) [unit of β_b per unit of θ_j]
        """
        theta = self.parameter_vector(params)
        E = self._regressor_data()["exponents"]
        out = np.zeros_like(E)
        for j in range(theta.size):
            Ej = E.copy()
            Ej[:, j] -= 1  # ∂(θ_j^e)/∂θ_j = e θ_j^(e−1)
            with np.errstate(divide="ignore", invalid="ignore"):
                val = E[:, j] * np.prod(
                    np.where(Ej < 0, 1.0, theta[None, :] ** np.maximum(Ej, 0)), axis=1
                )
            out[:, j] = np.where(E[:, j] > 0, val, 0.0)
        return out

    def regressor(self, q, qd, qdd) -> np.ndarray:
        """Y(q, q̇, q̈), shape (n_samples, n_joints, n_beta), with τ = Y @ beta(params).

        Derived on first use (then cached on disk like the rest of the model).

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n_samples, n_joints)
            Joint angles [rad], rates [rad/s] and accelerations [rad/s²].

        Returns
        -------
        ndarray, shape (n_samples, n_joints, n_beta) [N·m per unit of each monomial]
            Column b multiplies the monomial `beta_names` [b] of the parameters.

        Raises
        ------
        IdentifiabilityError
            The model is not polynomial in its parameters (no linear-in-parameters form).

        Examples
        --------
        >>> import numpy as np, physid
        >>> model = physid.load_model("manipulator")
        >>> q, qd, qdd = np.random.default_rng(2).normal(size=(3, 6, 4))
        >>> tau = model.regressor(q, qd, qdd) @ model.beta()
        >>> bool(np.allclose(tau, model.inverse_dynamics(q, qd, qdd)))
        True
        """
        self._regressor_data()
        n, cols = self._states((q, "q"), (qd, "qd"), (qdd, "qdd"))
        return self._regressor_eval(cols, n)

    def _regressor_eval(self, cols, n) -> np.ndarray:
        d = self._regressor_data()
        n_all = len(d["monomials"])
        Y = d["function"](*cols, n).reshape(self.n_joints, n_all, n)[:, d["keep"], :]
        return Y.transpose(2, 0, 1).copy()

    def base_parameters(
        self, params=None, *, n_states: int | None = None, seed: int = 0, rtol: float = 1e-9
    ) -> BaseParameters:
        """Identifiable combinations of the parameters (base parameters).

        The regressor Y is evaluated at random states (q uniform in [−π, π], q̇, q̈ standard
        normal), its columns scaled to unit norm, and factorised by QR with column pivoting; the
        numerical rank is the number of base parameters, each dependent column is expressed in the
        independent ones (base = β_ind + K β_dep). Then, symbolically, parameters that enter τ only
        through one common monomial are reported (e.g. "m1 and l1 enter only as m1*l1**2"), and
        the rank of ∂base/∂θ at ``params`` (nominal by default) says how many directions of θ are
        determined.

        Parameters
        ----------
        params : dict or array_like, optional
            Where to evaluate ∂base/∂θ (nominal values by default).
        n_states : int, optional
            Random states used (default max(30, 3·n_beta)).
        seed : int
            Seed of the random states.
        rtol : float
            Rank threshold on |R_ii| / |R_00|.
        """
        import scipy.linalg

        d = self._regressor_data()
        names = self.beta_names
        nb = len(names)
        ns = n_states or max(30, 3 * nb)
        rng = np.random.default_rng(seed)
        nj = self.n_joints
        q = rng.uniform(-np.pi, np.pi, (ns, nj))
        Y = self.regressor(q, rng.normal(size=(ns, nj)), rng.normal(size=(ns, nj))).reshape(
            ns * nj, nb
        )
        norms = np.linalg.norm(Y, axis=0)
        Ys = Y / np.where(norms > 0, norms, 1.0)
        _, R, perm = scipy.linalg.qr(Ys, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        rank = int(np.sum(diag > rtol * diag[0])) if diag.size else 0
        ind, dep = perm[:rank], perm[rank:]
        K = np.zeros((rank, nb))
        K[np.arange(rank), ind] = 1.0
        if dep.size:
            # W_dep = W_ind C (exact), so τ = W_ind (β_ind + C β_dep)
            C, *_ = np.linalg.lstsq(Y[:, ind], Y[:, dep], rcond=None)
            C[np.abs(C) < 1e-10] = 0.0
            K[:, dep] = C
        order = np.argsort(ind)  # list base parameters in β order
        K = K[order]
        ind_sorted = ind[order]
        base_names = tuple(_format_combination(K[k], names) for k in range(rank))
        # θ-level: every unidentifiable direction named by the one Combination path
        # (physid.models.identifiability.describe_direction), as every result names it
        from .identifiability import Combination, describe_direction

        E = d["exponents"]
        pnames = self.parameter_names
        combos = []
        for j in range(len(pnames)):
            if not np.any(E[:, j] > 0):
                text = (
                    f"{pnames[j]} does not enter the equations of motion: it cannot be identified"
                )
                combos.append(Combination((pnames[j],), f"{pnames[j]} (no effect)", {}, text))
        theta = self.parameter_vector(params)
        Jb = K @ self.beta_jacobian(theta) * theta[None, :]  # relative (dθ/θ) coordinates
        if Jb.size:
            _, s, Vt = np.linalg.svd(Jb)
            trank = int(np.sum(s > 1e-9 * s[0])) if s.size and s[0] > 0 else 0
            null = Vt[trank:].T
        else:
            trank, null = 0, np.eye(len(pnames))
        silent = {c.parameters[0] for c in combos}
        for v in null.T:
            if not np.any(np.abs(v) > 1e-6):
                continue
            c = describe_direction(v, pnames, beta_names=names)
            if not set(c.parameters) <= silent:
                combos.append(c)
        statements = [c.text for c in combos]
        no_effect = tuple(d["names"][b] for b in range(len(d["monomials"])) if b not in d["keep"])
        return BaseParameters(
            beta_names=names,
            n_beta=nb,
            n_base=rank,
            base_names=base_names,
            base_matrix=K,
            independent=tuple(names[b] for b in ind_sorted),
            no_effect=no_effect,
            parameter_names=pnames,
            theta_rank=trank,
            unidentifiable=tuple(statements),
            null_directions=null,
            combinations=tuple(combos),
        )

    # -- symbolic view ------------------------------------------------------------------------
    def symbolic_equations(self):
        """Re-derive the equations with readable sympy symbols (q1, qd1, qdd1, m1, ...).

        Returns a `physid.models.lagrange.ChainEquations`. Slow (sympy); not cached.
        """
        import sympy as sp

        from .lagrange import ChainEquations, derive_chain_equations
        from .spec import symbolic_chain

        sym = symbolic_chain(self._spec)
        eqs = derive_chain_equations(
            sym["transforms"],
            sym["masses"],
            sym["rotor_inertias"],
            sym["viscous"],
            sym["coulomb"],
            self._spec.gravity,
            sym["q"],
            sym["qd"],
            sym["qdd"],
            sym["theta"],
            kinetic=self.kinetic,
            axis_static=sym["axis_static"],
        )
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
