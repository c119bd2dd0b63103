"""Equations of motion from kinetic and potential energy (sympy), for serial chains of point masses.

Lagrange's equations of the second kind (Cedro & Janecki, eq. 1)::

    d/dt ∂K/∂q̇ − ∂K/∂q + ∂V/∂q = τ

with a kinetic energy quadratic in the joint rates, K = ½ q̇ᵀ M(q, θ) q̇, give

    τ = M(q) q̈ + c(q, q̇) + G(q) (+ friction),
    c_i = Σ_jk Γ_ijk q̇_j q̇_k,   Γ_ijk = ½ (∂M_ij/∂q_k + ∂M_ik/∂q_j − ∂M_jk/∂q_i)   (Christoffel),
    G_i = ∂V/∂q_i,   V = −Σ_k m_k g·p_k(q).

Two kinetic energies are offered:

* ``"exact"``: K = Σ_k ½ m_k |ṗ_k|² + Σ_k ½ J_k q̇_k², so M = Σ_k m_k J_kᵀ J_k + diag(J) with the
  translational Jacobians J_k = ∂p_k/∂q.
* ``"paper"``: the formula of Cedro & Janecki (section 2), K_k = ½ m_k Σ_j |∂p_k/∂q_j|² q̇_j² —
  only the squared term of each joint rate, no cross terms — so M is diagonal and equals the
  diagonal of the exact M. (The paper's printed K[k] sums over ``i = 1..3`` but indexes
  ``[[1]][[1]]``; read as ``[[i]][[i]]`` it is the squared norm of ∂p_k/∂q_j, which is what the
  surrounding text and the Mathematica semantics imply. We implement that reading.)

No ``simplify`` anywhere (slow on big expressions). Instead the expressions are kept small by
construction (`local_mass_matrix`): each entry M_ij is a sum of dot products taken in the frame of
joint i, so the base rotation never appears; small position vectors and dot products get a cheap
canonical trigonometric form (fu's TR10i folds c1 c2 − s1 s2 into cos(q1 + q2), TR5 turns sin²
into 1 − cos²), and terms are collected by joint-dependent factor so parameter-only coefficients
can be computed once. Common-subexpression elimination in `physid.models.codegen` does the rest.
The literal `lagrange_equations` is kept for checks on small systems.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "KINETIC_MODES",
    "ChainEquations",
    "chain_positions",
    "derive_chain_equations",
    "lagrange_equations",
    "christoffel_bias",
    "christoffel_bias_collected",
    "local_mass_matrix",
    "collect_q",
    "regressor_columns",
    "monomial_name",
    "theta_polynomial",
]

KINETIC_MODES = ("exact", "paper")


@dataclass(frozen=True)
class ChainEquations:
    """Symbolic equations of motion τ = M q̈ + c + G + F of a chain (sympy objects).

    Attributes
    ----------
    q, qd, qdd : tuple of sympy.Symbol
        Joint angles [rad], rates [rad/s], accelerations [rad/s²].
    theta : tuple of sympy.Symbol
        Parameters, in model order.
    mass_matrix : sympy.Matrix (nj × nj)
        M(q, θ) [kg·m²].
    coriolis : tuple of sympy.Expr
        c(q, q̇, θ) [N·m], Coriolis and centrifugal torques.
    gravity : tuple of sympy.Expr
        G(q, θ) = ∂V/∂q [N·m] (the torque the motors must supply to hold the arm still).
    friction : tuple of sympy.Expr
        F(q̇, θ) = viscous·q̇ + coulomb·sign(q̇) [N·m].
    positions : tuple of sympy.Matrix (3 × 1)
        p_k(q, θ) [m], origins of the link frames in the base frame.
    """

    q: tuple
    qd: tuple
    qdd: tuple
    theta: tuple
    mass_matrix: object
    coriolis: tuple
    gravity: tuple
    friction: tuple
    positions: tuple

    @property
    def tau(self) -> tuple:
        """Inverse dynamics τ = M q̈ + c + G + F, one expression per joint [N·m]."""
        n = len(self.q)
        M = self.mass_matrix
        return tuple(
            sum((M[i, j] * self.qdd[j] for j in range(n)), 0)
            + self.coriolis[i]
            + self.gravity[i]
            + self.friction[i]
            for i in range(n)
        )


def chain_positions(transforms):
    """Origins p_k of the frames of a serial chain: p_k = (T_1 T_2 ⋯ T_k)[0:3, 3].

    Parameters
    ----------
    transforms : sequence of sympy.Matrix (4 × 4)
        Homogeneous transform of each link relative to the previous frame.
    """
    import sympy as sp

    positions = []
    T = sp.eye(4)
    for Tk in transforms:
        T = T * Tk
        positions.append(T[0:3, 3])
    return positions


def _mdiff(M, x):
    """Element-wise ∂M/∂x (sympy's Matrix.diff takes a much slower array-derivative path)."""
    import sympy as sp

    return sp.Matrix(M.rows, M.cols, [e.diff(x) if e != 0 else 0 for e in M])


def _jacobian(p, q):
    """∂p/∂q for a column vector p (3 × n)."""
    import sympy as sp

    return sp.Matrix(len(p), len(q), lambda i, j: p[i].diff(q[j]))


def _compact(expr):
    """Cheap trigonometric compaction: expand, then fold c1 c2 − s1 s2 → cos(q1 + q2) (fu's TR10i).

    Position vectors of DH chains with parallel axes collapse to sums of cos/sin of angle sums;
    this is fast on the small position expressions (unlike ``simplify`` on the mass matrix).
    """
    import sympy as sp
    from sympy.simplify.fu import TR10i

    expr = sp.expand(expr)
    if not expr.has(sp.sin, sp.cos):
        return expr
    return TR10i(expr)


def local_mass_matrix(transforms, masses, q, kinetic: str = "exact", axis_static=None):
    """M = Σ_k m_k J_kᵀ J_k (exact) or its diagonal (paper), in compact form.

    M_ij (i ≤ j) = Σ_{k ≥ j} m_k (∂p_k/∂q_i)·(∂p_k/∂q_j). Dot products do not change under a
    rotation, so both derivatives are taken in the frame of joint i, where p_k depends only on
    q_i … q_k: the base rotation R_0,i−1(q_1 … q_{i−1}) drops out instead of having to cancel
    through sin² + cos² = 1 (which no cheap simplification finds). When T_i = Rz(q_i) S_i (DH
    joints, ``axis_static[i] = S_i``) we use the frame after Rz(q_i): there ∂p_k/∂q_i = z × p_k and
    p_k no longer depends on q_i either.

    Small dot products are put in a canonical trigonometric form (`_pythagorean`); when all of
    them are, M is returned collected by joint-dependent factor (`collect_q`) and the flag is True.

    Returns
    -------
    (sympy.Matrix, bool)
    """
    import sympy as sp

    n = len(q)
    M = sp.zeros(n, n)
    canonical = True
    for i in range(n):
        static = axis_static[i] if axis_static is not None else None
        T = static if static is not None else transforms[i]
        for k in range(i, n):
            if k > i:
                T = T * transforms[k]
            P = [_compact(e) for e in T[0:3, 3]]  # p_k in the frame of joint i
            if static is not None:
                d_i = [-P[1], P[0], 0]  # z × p
            else:
                d_i = [e.diff(q[i]) for e in P]
            js = range(i, k + 1) if kinetic == "exact" else (i,)
            for j in js:
                d_j = d_i if j == i else [e.diff(q[j]) for e in P]
                dot = d_i[0] * d_j[0] + d_i[1] * d_j[1] + d_i[2] * d_j[2]
                if canonical:
                    dot, ok = _pythagorean(dot)
                    canonical = canonical and ok
                M[i, j] += masses[k] * dot
    for i in range(n):
        for j in range(i + 1, n):
            M[j, i] = M[i, j]
    if canonical:
        M = M.applyfunc(lambda e: collect_q(e, q))
    return M, canonical


#: Largest dot product (sympy count_ops) that `_pythagorean` canonicalises; bigger ones (long
#: chains with twists) would expand into thousands of terms, so they stay as trees.
CANONICAL_OPS_LIMIT = 400


def _pythagorean(expr):
    """Canonical form of a small trigonometric polynomial: fold products into angle sums
    (TR10i), replace sin² by 1 − cos² (TR5), expand, fold again. (e.g. (l2 + l3 cos q3)² +
    (l3 sin q3)² → l2² + 2 l2 l3 cos q3 + l3²). Returns (expr, done)."""
    import sympy as sp
    from sympy.simplify.fu import TR5, TR10i

    if sp.count_ops(expr) > CANONICAL_OPS_LIMIT:
        return expr, False
    e = sp.expand(expr)
    if not e.has(sp.sin, sp.cos):
        return e, True
    e = TR10i(e)
    e = sp.expand(TR5(e))
    return TR10i(e), True


def collect_q(expr, q):
    """Write an expanded expression as Σ_f C_f(θ) f(q, …): one parameter-only coefficient per
    distinct joint-dependent factor, so generated code can evaluate the C_f once per parameter
    set and only the f at each call."""
    import sympy as sp

    qset = set(q)
    groups: dict = {}
    for term in sp.Add.make_args(sp.expand(expr)):
        coeff, qpart = [], []
        for f in sp.Mul.make_args(term):
            (qpart if f.free_symbols & qset else coeff).append(f)
        key = sp.Mul(*qpart)
        groups[key] = groups.get(key, 0) + sp.Mul(*coeff)
    return sp.Add(*[sp.factor_terms(c) * key for key, c in groups.items()])


def christoffel_bias_collected(M, q, qd):
    """c_i = Σ_j Γ_ijj q̇_j² + 2 Σ_{j<k} Γ_ijk q̇_j q̇_k, each Γ_ijk collected by joint-dependent
    factor (see `collect_q`)."""
    import sympy as sp

    n = len(q)
    dM = [
        [[M[a, b].diff(q[c]) for c in range(n)] for b in range(n)] for a in range(n)
    ]  # ∂M_ab/∂q_c
    out = []
    for i in range(n):
        terms = []
        for j in range(n):
            for k in range(j, n):
                gamma = sp.Rational(1, 2) * (dM[i][j][k] + dM[i][k][j] - dM[j][k][i])
                if gamma == 0:
                    continue
                weight = 1 if j == k else 2
                gamma = collect_q(weight * gamma, q)
                if gamma != 0:
                    terms.append(gamma * qd[j] * qd[k])
        out.append(sp.Add(*terms))
    return tuple(out)


def christoffel_bias(M, q, qd):
    """c_i = Σ_jk Γ_ijk q̇_j q̇_k = [Ṁ q̇ − ½ ∂(q̇ᵀ M q̇)/∂q]_i for a symmetric M(q)."""
    import sympy as sp

    n = len(q)
    dM = [_mdiff(M, qk) for qk in q]  # ∂M/∂q_k
    Mdot = sp.zeros(n, n)
    for k in range(n):
        Mdot += dM[k] * qd[k]
    qdv = sp.Matrix(qd)
    first = Mdot * qdv
    return tuple(first[i] - sp.Rational(1, 2) * (qdv.T * dM[i] * qdv)[0, 0] for i in range(n))


def lagrange_equations(K, V, q, qd, qdd):
    """Literal Euler–Lagrange equations τ_i = d/dt ∂K/∂q̇_i − ∂K/∂q_i + ∂V/∂q_i.

    ``d/dt`` of a function of (q, q̇) is Σ_j (∂/∂q_j q̇_j + ∂/∂q̇_j q̈_j). Slow on big energies;
    used for checks and for small hand-written models.
    """
    out = []
    for i in range(len(q)):
        dK = K.diff(qd[i])
        ddt = sum(dK.diff(q[j]) * qd[j] + dK.diff(qd[j]) * qdd[j] for j in range(len(q)))
        out.append(ddt - K.diff(q[i]) + V.diff(q[i]))
    return tuple(out)


def derive_chain_equations(
    transforms,
    masses,
    rotor_inertias,
    viscous,
    coulomb,
    gravity,
    q,
    qd,
    qdd,
    theta,
    kinetic: str = "exact",
    axis_static=None,
) -> ChainEquations:
    """Equations of motion of a serial chain of point masses (see module docstring).

    Parameters
    ----------
    transforms : sequence of sympy.Matrix (4 × 4)
        Link transforms T_k(q, θ) relative to the previous frame.
    masses, rotor_inertias, viscous, coulomb : sequence of sympy.Expr
        Per joint: point mass m_k [kg] at the origin of frame k; rotor/link inertia J_k [kg·m²]
        adding ½ J_k q̇_k²; viscous [N·m·s/rad] and Coulomb [N·m] friction coefficients.
    gravity : sequence of 3 numbers
        Gravity vector g [m/s²] in the base frame; V = −Σ m_k g·p_k.
    kinetic : {"exact", "paper"}
        Kinetic energy form.
    axis_static : sequence of (sympy.Matrix or None), optional
        Per joint, S_k with T_k = Rz(q_k) S_k when known (DH joints), else None; it lets
        `local_mass_matrix` work in the joint's own rotating frame (smaller expressions).
    """
    import sympy as sp

    n = len(q)
    positions = [p.applyfunc(_compact) for p in chain_positions(transforms)]
    jac = [_jacobian(p, q) for p in positions]  # 3 × n each: ∂p_k/∂q
    gvec = sp.Matrix([sp.nsimplify(g) if float(g).is_integer() else sp.Float(g) for g in gravity])
    if kinetic not in KINETIC_MODES:  # pragma: no cover - validated by the caller
        raise ValueError(kinetic)
    M, canonical = local_mass_matrix(transforms, masses, q, kinetic, axis_static=axis_static)
    for k in range(n):
        M[k, k] += rotor_inertias[k]
    coriolis = christoffel_bias_collected(M, q, qd) if canonical else christoffel_bias(M, q, qd)
    # G_i = ∂V/∂q_i = −Σ_k m_k gᵀ ∂p_k/∂q_i
    grav = tuple(
        -sum((m * (gvec.T * J[:, i])[0, 0] for m, J in zip(masses, jac, strict=False)), 0)
        for i in range(n)
    )
    if canonical:
        grav = tuple(collect_q(e, q) for e in grav)
    friction = tuple(viscous[i] * qd[i] + coulomb[i] * sp.sign(qd[i]) for i in range(n))
    return ChainEquations(
        q=tuple(q),
        qd=tuple(qd),
        qdd=tuple(qdd),
        theta=tuple(theta),
        mass_matrix=M,
        coriolis=coriolis,
        gravity=grav,
        friction=friction,
        positions=tuple(positions),
    )


# --------------------------------------------------------------------------------------------
# Linear-in-parameters form: polynomials in θ with coefficients that are functions of q.
# --------------------------------------------------------------------------------------------


def theta_polynomial(expr, theta) -> dict:
    """Split ``expr`` into {exponent tuple: coefficient} as a polynomial in the symbols ``theta``.

    Coefficients may be any expressions free of ``theta`` (functions of q). Raises
    ``sympy.PolynomialError`` when ``expr`` is not polynomial in ``theta``.
    """
    import sympy as sp

    expr = sp.sympify(expr, strict=True)  # sympy objects only: strict refuses text
    if expr == 0:
        return {}
    if not (expr.free_symbols & set(theta)):
        return {(0,) * len(theta): expr}
    poly = sp.Poly(expr, *theta, domain="EX")
    return {
        mon: coeff.as_expr() if hasattr(coeff, "as_expr") else coeff
        for mon, coeff in poly.as_dict(native=False).items()
    }


def regressor_columns(
    transforms,
    masses,
    rotor_inertias,
    viscous,
    coulomb,
    gravity,
    q,
    qd,
    qdd,
    theta,
    kinetic: str = "exact",
    axis_static=None,
):
    """τ = Σ_β Y_β(q, q̇, q̈) β(θ): the monomials β and their regressor columns Y_β.

    Lagrange's equations are linear in (K, V), and K, V, F are polynomials in θ, so each
    monomial β contributes its own Euler–Lagrange column computed from M_β(q), V_β(q), F_β(q̇):
    Y_β = M_β q̈ + c(M_β, q̇) + ∂V_β/∂q + F_β.

    Returns
    -------
    monomials : list of exponent tuples (one entry per θ)
    columns : list of tuple of sympy.Expr (nj entries each)

    Raises ``sympy.PolynomialError`` when the model is not polynomial in θ.
    """
    import sympy as sp

    n = len(q)
    M, canonical = local_mass_matrix(transforms, masses, q, kinetic, axis_static=axis_static)
    for k in range(n):
        M[k, k] += rotor_inertias[k]
    M_poly: dict = {}
    for a in range(n):
        for b in range(a + 1):
            for mon, c in theta_polynomial(M[a, b], theta).items():
                E = M_poly.setdefault(mon, sp.zeros(n, n))
                E[a, b] = E[b, a] = c
    gvec = sp.Matrix(
        [sp.Float(g) if not float(g).is_integer() else sp.Integer(int(g)) for g in gravity]
    )
    V = -sum(
        (
            m * (gvec.T * p.applyfunc(_compact))[0, 0]
            for m, p in zip(masses, chain_positions(transforms), strict=False)
        ),
        0,
    )
    V_poly = theta_polynomial(V, theta)
    F_poly: dict = {}
    for k in range(n):
        for coeffs, func in ((viscous[k], qd[k]), (coulomb[k], sp.sign(qd[k]))):
            for mon, c in theta_polynomial(coeffs, theta).items():
                vec = F_poly.setdefault(mon, [0] * n)
                vec[k] = vec[k] + c * func
    monomials = sorted(
        set(M_poly) | set(V_poly) | set(F_poly), key=lambda m: (sum(m), [-e for e in m])
    )
    bias = christoffel_bias_collected if canonical else christoffel_bias
    columns = []
    for mon in monomials:
        col = [0] * n
        if mon in M_poly:
            Mb = M_poly[mon]
            c = bias(Mb, q, qd)
            col = [col[i] + sum((Mb[i, j] * qdd[j] for j in range(n)), 0) + c[i] for i in range(n)]
        if mon in V_poly:
            col = [col[i] + V_poly[mon].diff(q[i]) for i in range(n)]
        if mon in F_poly:
            col = [col[i] + F_poly[mon][i] for i in range(n)]
        columns.append(tuple(col))
    return monomials, columns


def monomial_name(mon, names) -> str:
    """Readable name of a monomial, e.g. ``m2*l2**2`` (``1`` for the constant monomial)."""
    parts = []
    for e, name in zip(mon, names, strict=False):
        if e == 1:
            parts.append(name)
        elif e > 1:
            parts.append(f"{name}**{e}")
    return "*".join(parts) if parts else "1"
