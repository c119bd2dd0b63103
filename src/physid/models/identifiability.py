"""Which parameters, or combinations of parameters, the data can determine.

Two questions, answered the same way: find the directions in parameter space along which the
predicted forces do not change, then name them.

*Structural* identifiability (`structural_identifiability`) asks it of the model alone: the
sensitivity ``∂τ/∂θ`` (the model's ``parameter_jacobian``) is evaluated at many random states
``(q, q̇, q̈)`` and stacked; a direction in its null space cannot be seen by any experiment. For the
paper's arm, ``T1`` has no translation, so the point mass of link 1 sits on the axis of joint 1 and
``m1`` and ``l1`` enter the equations of motion only through the rod inertia ``J1 = m1*l1**2/12``
(section 2 of Cedro & Janecki): the direction ``(δm1/m1, δl1/l1) ∝ (2, -1)`` leaves every torque
unchanged.

*Numerical* identifiability (`numeric_identifiability`) asks it of one experiment: the singular
values of the column-scaled Jacobian of the residuals at a given parameter vector.

Columns are scaled by the parameter values, so every quantity here is a *relative* sensitivity
(``∂τ/∂ln θ``): the directions are in ``δθ/θ`` and are independent of units. For a monomial
combination ``Π θ_i^{a_i}`` the null direction ``v`` satisfies ``a · v = 0`` exactly, whatever the
values of θ, which is how the directions are turned into names such as ``"m1*l1**2"``.

`hold_plan` turns the combinations into the default remedy: hold one parameter of each at a given
value (the estimator's initial value) so that the rest of the problem is well posed.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from .._progress import working
from ..errors import IdentifiabilityError, InputError, PhysidWarning, arg

__all__ = [
    "IdentifiabilityWarning",
    "Combination",
    "StructuralIdentifiability",
    "NumericIdentifiability",
    "structural_identifiability",
    "numeric_identifiability",
    "hold_plan",
    "describe_direction",
    "raise_if_not_excited",
    "svd_tall",
]

#: Relative singular value below which a direction counts as structurally invisible. Exact
#: structural null directions come out at ~1e-16 (round-off); genuine ones at > 1e-6.
STRUCTURAL_RTOL = 1e-9

#: Relative singular value below which one experiment counts as not determining a direction.
#: Below 1e-7 a relative error of 1e-16 in the data is amplified beyond 1e-9 in the parameters
#: and the least-squares steps along that direction are dominated by round-off.
NUMERIC_RTOL = 1e-7


class IdentifiabilityWarning(PhysidWarning):
    """Warning: parameters are held fixed because the data cannot determine them.

    A `physid.errors.PhysidWarning`: the command line shows its arguments as flags.
    """


@dataclass(frozen=True)
class Combination:
    """One combination of parameters that the data determine, although its factors are not.

    Attributes
    ----------
    parameters : tuple of str
        The parameters involved, in the model's order, e.g. ``("m1", "l1")``.
    expression : str
        The identifiable combination, e.g. ``"m1*l1**2"``; a generic description when the
        direction is not the invariance of a monomial.
    direction : dict name -> float
        Unit null direction in relative coordinates ``δθ/θ`` (only the parameters involved).
    text : str
        In words, e.g. ``"m1 and l1 enter only as m1*l1**2"``.
    """

    parameters: tuple[str, ...]
    expression: str
    direction: Mapping[str, float]
    text: str


@dataclass(frozen=True)
class StructuralIdentifiability:
    """Result of `structural_identifiability`.

    Attributes
    ----------
    parameter_names : tuple of str
    identifiable : tuple of str
        Parameters that appear in no unidentifiable combination.
    combinations : tuple of Combination
        Each unidentifiable direction, named.
    singular_values : ndarray, shape (n_params,)
        Relative singular values (largest = 1) of the stacked, column-scaled sensitivity.
    not_excitable : tuple of str
        Parameters that have no effect on the forces at all (zero sensitivity column).
    """

    parameter_names: tuple[str, ...]
    identifiable: tuple[str, ...]
    combinations: tuple[Combination, ...]
    singular_values: np.ndarray = field(repr=False)
    not_excitable: tuple[str, ...] = ()

    @property
    def expressions(self) -> list[str]:
        """The identifiable combinations, e.g. ``["m1*l1**2"]``."""
        return [c.expression for c in self.combinations]

    @property
    def texts(self) -> list[str]:
        """The combinations in words, e.g. ``["m1 and l1 enter only as m1*l1**2"]``."""
        return [c.text for c in self.combinations]

    def summary(self) -> str:
        """One line per finding."""
        if not self.combinations and not self.not_excitable:
            return "all parameters are structurally identifiable"
        lines = [c.text for c in self.combinations]
        lines += [f"{name} has no effect on the forces" for name in self.not_excitable]
        return "; ".join(lines)


@dataclass(frozen=True)
class NumericIdentifiability:
    """Result of `numeric_identifiability`: how well one experiment determines the parameters.

    Attributes
    ----------
    parameter_names : tuple of str
        The columns analysed (the free parameters).
    singular_values : ndarray
        Singular values of the column-scaled Jacobian divided by the largest (1 first).
    condition_number : float
        Largest over smallest singular value (inf when singular).
    weak_directions : tuple of Combination
        Directions with a relative singular value below ``rtol``, named.
    not_excited : tuple of str
        Parameters whose Jacobian column is zero: the data do not excite them at all.
    rtol : float
    """

    parameter_names: tuple[str, ...]
    singular_values: np.ndarray = field(repr=False)
    condition_number: float
    weak_directions: tuple[Combination, ...]
    not_excited: tuple[str, ...]
    rtol: float

    @property
    def ok(self) -> bool:
        """True when no direction is weak and every parameter is excited."""
        return not self.weak_directions and not self.not_excited

    def summary(self) -> str:
        """One line: condition number and the weak directions in words."""
        head = f"condition number of the scaled Jacobian {self.condition_number:.3g}"
        extra = [c.text for c in self.weak_directions]
        extra += [f"{n} is not excited by the data (zero sensitivity)" for n in self.not_excited]
        return head + ("; " + "; ".join(extra) if extra else "")


# ---------------------------------------------------------------------- naming
def _parse_monomials(
    beta_names: Sequence[str], names: Sequence[str]
) -> list[tuple[str, np.ndarray]]:
    """Exponent vectors of the beta names that are monomials in the parameters (others skipped)."""
    import sympy as sp

    from ..errors import ExpressionError
    from ..expressions import parse_expression

    symbols = {n: sp.Symbol(n) for n in names}
    out = []
    for text in beta_names:
        try:  # parsed by the whitelist, never sympify'd: names may come from a user's file
            expr = parse_expression(str(text), symbols)
            poly = sp.Poly(expr, *symbols.values())
        except (ExpressionError, sp.PolynomialError):
            continue
        if len(poly.terms()) != 1:
            continue
        exponents, _ = poly.terms()[0]
        out.append((str(text), np.array(exponents, dtype=float)))
    return out


def _format_monomial(names: Sequence[str], exponents: Sequence[Fraction]) -> str:
    parts = []
    for name, a in zip(names, exponents, strict=True):
        if a == 0:
            continue
        if a == 1:
            parts.append(name)
        elif a.denominator == 1:
            parts.append(f"{name}**{a.numerator}")
        else:
            parts.append(f"{name}**({a.numerator}/{a.denominator})")
    return "*".join(parts)


def _join_words(items: Sequence[str]) -> str:
    items = list(items)
    if len(items) <= 1:
        return "".join(items)
    return ", ".join(items[:-1]) + " and " + items[-1]


def describe_direction(
    direction,
    names: Sequence[str],
    *,
    beta_names: Sequence[str] | None = None,
    cutoff: float = 1e-6,
) -> Combination:
    """Name a null direction (relative coordinates ``δθ/θ``) as the combination it leaves unchanged.

    Parameters
    ----------
    direction : array_like, shape (n_params,)
        Null direction in relative coordinates.
    names : sequence of str
        Parameter names, same order.
    beta_names : sequence of str, optional
        The model's linear-parameter names (``model.beta_names``), used to name directions that
        involve more than two parameters.
    cutoff : float
        Components smaller than ``cutoff`` times the largest are taken as zero.

    Returns
    -------
    Combination

    Examples
    --------
    >>> describe_direction([2.0, -1.0], ["m1", "l1"]).text
    'm1 and l1 enter only as m1*l1**2'
    """
    v = np.asarray(direction, dtype=float)
    if v.shape != (len(names),):
        raise InputError(
            f"direction must have one entry per name ({len(names)}); got shape {v.shape}."
        )
    big = np.abs(v) > cutoff * np.abs(v).max()
    support = [n for n, b in zip(names, big, strict=True) if b]
    vs = v[big] / np.linalg.norm(v[big])
    if vs[np.argmax(np.abs(vs))] < 0:
        vs = -vs
    direction_map = {n: float(x) for n, x in zip(support, vs, strict=True)}
    expression = None
    if len(support) == 1:
        text = f"{support[0]} has no effect on the forces"
        return Combination(tuple(support), f"{support[0]} (no effect)", direction_map, text)
    if len(support) == 2:
        # invariant exponents a with a . v = 0:  a = (v_b, -v_a), scaled to small integers
        a = np.array([vs[1], -vs[0]])
        a = a / np.min(np.abs(a))
        if a[np.argmax(np.abs(a))] < 0:
            a = -a
        fracs = [Fraction(float(x)).limit_denominator(6) for x in a]
        if np.allclose([float(f) for f in fracs], a, rtol=1e-6, atol=1e-9) and all(
            f > 0 for f in fracs
        ):
            expression = _format_monomial(support, fracs)
    if expression is None and beta_names:
        idx = [list(names).index(n) for n in support]
        for text_b, exps in sorted(_parse_monomials(beta_names, names), key=lambda e: e[1].sum()):
            used = exps > 0
            if (
                used.any()
                and set(np.nonzero(used)[0]) <= set(idx)
                and set(np.nonzero(used)[0]) == set(idx)
            ):
                if abs(float(exps[idx] @ vs)) < 1e-6 * np.abs(exps).sum():
                    expression = text_b
                    break
    if expression is None:
        terms = " ".join(f"{x:+.3g}·δ{n}/{n}" for n, x in direction_map.items())
        expression = f"combination of {_join_words(support)}"
        text = (
            f"{_join_words(support)} are not separately identifiable (the direction {terms} is "
            "invisible)"
        )
    else:
        text = f"{_join_words(support)} enter only as {expression}"
    return Combination(tuple(support), expression, direction_map, text)


def _sparse_null_basis(null: np.ndarray, tol: float = 1e-8) -> list[np.ndarray]:
    """Reduced row echelon form of a null-space basis (k, p): sparse, one vector per direction."""
    a = np.array(null, dtype=float)
    k, p = a.shape
    row = 0
    for col in range(p):
        if row >= k:
            break
        pivot = row + int(np.argmax(np.abs(a[row:, col])))
        if abs(a[pivot, col]) < tol:
            continue
        a[[row, pivot]] = a[[pivot, row]]
        a[row] /= a[row, col]
        for r in range(k):
            if r != row:
                a[r] -= a[r, col] * a[row]
        row += 1
    a[np.abs(a) < tol] = 0.0
    return [r / np.linalg.norm(r) for r in a[:row]]


# ---------------------------------------------------------------------- structural
def _random_states(n_joints: int, n_states: int, rng: np.random.Generator):
    q = rng.uniform(-np.pi, np.pi, (n_states, n_joints))
    qd = rng.normal(0.0, 1.0, (n_states, n_joints))
    qdd = rng.normal(0.0, 1.0, (n_states, n_joints))
    return q, qd, qdd


def structural_identifiability(
    model,
    params: Mapping[str, float] | None = None,
    *,
    n_states: int = 64,
    seed: int = 0,
    rtol: float = STRUCTURAL_RTOL,
) -> StructuralIdentifiability:
    """Find the parameters and combinations no experiment can determine, from the model alone.

    The sensitivity ``∂τ/∂θ · diag(θ)`` (shape ``(n_states·n_joints, n_params)``) is evaluated at
    ``n_states`` random states (angles uniform on [-π, π], rates and accelerations standard normal)
    and decomposed by SVD; right singular vectors with a relative singular value below ``rtol``
    are the invisible directions. They are brought to reduced row-echelon form (so each involves
    as few parameters as possible) and named with `describe_direction`.

    Parameters
    ----------
    model : ChainModel
        Needs ``parameter_names``, ``parameters``, ``n_joints`` and ``parameter_jacobian``;
        ``beta_names`` is used for naming when present.
    params : mapping name -> value, optional
        Where to evaluate (default: the model's nominal values). For models linear in monomials of
        θ the answer does not depend on it, provided no value is zero.
    n_states : int
        Number of random states (each gives ``n_joints`` rows).
    seed : int
        Seed of the random states (the answer is the same for almost every draw).
    rtol : float
        Relative singular-value threshold.

    Returns
    -------
    StructuralIdentifiability

    Examples
    --------
    >>> import physid
    >>> structural_identifiability(physid.load_model("manipulator")).texts  # doctest: +SKIP
    ['m1 and l1 enter only as m1*l1**2']
    """
    names = tuple(model.parameter_names)
    values = dict(model.parameters)
    if params:
        values.update({k: float(v) for k, v in params.items()})
    theta = np.array([values[n] for n in names], dtype=float)
    scale = np.where(theta != 0.0, np.abs(theta), 1.0)
    rng = np.random.default_rng(seed)
    q, qd, qdd = _random_states(int(model.n_joints), int(n_states), rng)
    with working(f"physid: identifiability check of {len(names)} parameters"):
        jac = np.asarray(model.parameter_jacobian(q, qd, qdd, values), dtype=float)
    with np.errstate(all="ignore"):
        scaled = jac.reshape(-1, len(names)) * scale
    _check_finite_sensitivity(scaled, names, theta)
    col_norm = np.linalg.norm(scaled, axis=0)
    dead = col_norm <= 1e-12 * max(col_norm.max(), 1e-300)
    not_excitable = tuple(n for n, d in zip(names, dead, strict=True) if d)
    s, vt = svd_tall(scaled)
    rel = s / s[0] if s[0] > 0 else s
    null = vt[rel < rtol]
    # directions that are a single dead column are reported as not excitable, not as combinations
    combos = []
    beta_names = getattr(model, "beta_names", None)
    if null.size:
        for v in _sparse_null_basis(null):
            c = describe_direction(v, names, beta_names=beta_names)
            if len(c.parameters) > 1:
                combos.append(c)
    involved = {p for c in combos for p in c.parameters} | set(not_excitable)
    identifiable = tuple(n for n in names if n not in involved)
    rel.setflags(write=False)
    return StructuralIdentifiability(names, identifiable, tuple(combos), rel, not_excitable)


def _check_finite_sensitivity(scaled: np.ndarray, names: Sequence[str], theta: np.ndarray) -> None:
    """Refuse parameter values at which the model's sensitivities overflow (e.g. a start value
    of 1e308): every direction would look invisible and every parameter be held."""
    names = list(names)
    finite = np.all(np.isfinite(scaled), axis=0)
    norms = np.linalg.norm(np.where(np.isfinite(scaled), scaled, 0.0), axis=0)
    seen = norms[finite & (norms > 0)]
    typical = float(np.median(seen)) if seen.size else 0.0
    # a term 1e12 times the typical one hides every other below the SVD's threshold
    loud = ~finite | ((norms > _DOMINANCE * typical) if typical > 0 else False)
    if not np.any(loud):
        return
    idx = np.flatnonzero(loud)
    worst = int(idx[np.argmax(np.abs(theta[idx]))])
    also = [names[k] for k in idx if k != worst]
    values = f"{names[worst]} = {theta[worst]:.3g}" + (
        f" (its term shared with {', '.join(also)})" if also else ""
    )
    raise InputError(
        f"the model's torque at {values} is out of scale with every other parameter's (its "
        f"term is more than {_DOMINANCE:.0e} times the typical one, or overflows float64): no "
        "other parameter could be seen beside it, and the fit would hold them all. Give values "
        f"of the order of the physical ones ({arg('initial', '{NAME: VALUE}', cli='NAME=VALUE')} "
        "or the model file's values)."
    )


#: Largest ratio of one parameter's sensitivity term to the typical one that
#: `structural_identifiability` accepts (beyond it the others fall below its threshold).
_DOMINANCE = 1e12


# ---------------------------------------------------------------------- hold plan
def hold_plan(
    analysis: StructuralIdentifiability,
    initial: Mapping[str, float],
    fixed: Mapping[str, float] | None = None,
    *,
    warn: bool = True,
) -> dict[str, float]:
    """Which parameters to hold, and at what value, so the remaining ones are identifiable.

    For each unidentifiable combination that no user-fixed parameter already resolves, the *last*
    parameter of the combination in the model's order is held at its ``initial`` value (for the
    manipulator that is the length ``l1`` of ``m1*l1**2``: a length is easier to measure with a
    ruler than a mass inside an assembled arm). A warning names the combination and the held value.

    Parameters
    ----------
    analysis : StructuralIdentifiability
    initial : mapping name -> value
        Values to hold at.
    fixed : mapping name -> value, optional
        What the user fixed; returned too, and it resolves the combinations it touches.
    warn : bool
        Emit an `IdentifiabilityWarning` for each parameter held by default.

    Returns
    -------
    dict name -> value
        The user's ``fixed`` plus the parameters held by default.
    """
    plan = {k: float(v) for k, v in (fixed or {}).items()}
    unknown = set(plan) - set(analysis.parameter_names)
    if unknown:
        raise InputError(
            f"fixed names unknown parameter(s) {sorted(unknown)}; the model's parameters are "
            f"{list(analysis.parameter_names)}."
        )
    for combo in analysis.combinations:
        if any(p in plan for p in combo.parameters):
            continue
        hold = combo.parameters[-1]
        plan[hold] = float(initial[hold])
        if warn:
            warnings.warn(
                f"{combo.text}: the data cannot separate them, so {hold} is held at its initial "
                f"value {plan[hold]:g} and only {combo.expression} is meaningful. Pass "
                f"{arg('fixed', f'{{{hold!r}: VALUE}}', cli=f'{hold}=VALUE')} with a measured "
                "value to choose, or fix another parameter of the combination.",
                IdentifiabilityWarning,
                stacklevel=3,
            )
    for name in analysis.not_excitable:
        if name not in plan:
            plan[name] = float(initial[name])
            if warn:
                warnings.warn(
                    f"{name} has no effect on the model's forces; it is held at {plan[name]:g}.",
                    IdentifiabilityWarning,
                    stacklevel=3,
                )
    return plan


# ---------------------------------------------------------------------- numeric
def svd_tall(a) -> tuple[np.ndarray, np.ndarray]:
    """Singular values and right singular vectors of a tall matrix, through its R factor.

    ``A = QR`` and ``R = U' S Vᵀ`` give ``A = (Q U') S Vᵀ``: the same ``S`` and ``V`` as the SVD of
    ``A`` at the cost of one Householder QR, without forming the tall ``U``.

    Returns
    -------
    s : ndarray, shape (p,)
        Singular values, largest first.
    vt : ndarray, shape (p, p)
        Right singular vectors as rows.
    """
    a = np.asarray(a, dtype=float)
    r = np.linalg.qr(a, mode="r") if a.shape[0] > a.shape[1] else a
    _, s, vt = np.linalg.svd(r, full_matrices=False)
    return s, vt


def numeric_identifiability(
    jacobian,
    names: Sequence[str],
    scale=None,
    *,
    rtol: float = NUMERIC_RTOL,
    beta_names: Sequence[str] | None = None,
) -> NumericIdentifiability:
    """Singular-value analysis of one experiment's Jacobian, with the weak directions named.

    Parameters
    ----------
    jacobian : array_like, shape (n_residuals, n_params)
        ``∂e/∂θ`` of the residuals (any row scaling).
    names : sequence of str
        Parameter names of the columns.
    scale : array_like, shape (n_params,), optional
        Column scale, normally ``|θ|`` so the analysis is in relative terms (default: ones).
    rtol : float
        Directions with ``σ/σ_max < rtol`` are reported as weak.
    beta_names : sequence of str, optional
        Passed to `describe_direction`.

    Returns
    -------
    NumericIdentifiability

    Examples
    --------
    >>> import numpy as np
    >>> a = np.random.default_rng(0).normal(size=(50, 1))
    >>> jac = np.column_stack([a[:, 0], 2 * a[:, 0], np.ones(50)])   # col 2 = 2 x col 1
    >>> numeric_identifiability(jac, ["a", "b", "c"]).weak_directions[0].parameters
    ('a', 'b')
    """
    jac = np.asarray(jacobian, dtype=float)
    names = tuple(names)
    if jac.ndim != 2 or jac.shape[1] != len(names):
        raise InputError(
            f"jacobian must have shape (n_residuals, {len(names)}) (one column per name); got "
            f"{jac.shape}."
        )
    scale = np.ones(len(names)) if scale is None else np.asarray(scale, dtype=float)
    scaled = jac * scale
    col_norm = np.linalg.norm(scaled, axis=0)
    dead = col_norm <= 1e-12 * max(col_norm.max(), 1e-300)
    not_excited = tuple(n for n, d in zip(names, dead, strict=True) if d)
    s, vt = svd_tall(scaled)
    rel = s / s[0] if s[0] > 0 else s
    cond = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    weak = []
    live = ~dead
    if live.sum() >= 1:
        s_live, vt_live = (s, vt) if live.all() else svd_tall(scaled[:, live])
        rel_live = s_live / s_live[0]
        live_names = [n for n, ok in zip(names, live, strict=True) if ok]
        for v in vt_live[rel_live < rtol]:
            weak.append(describe_direction(v, live_names, beta_names=beta_names, cutoff=1e-3))
    rel.setflags(write=False)
    return NumericIdentifiability(names, rel, cond, tuple(weak), not_excited, float(rtol))


def raise_if_not_excited(analysis: NumericIdentifiability, where: str) -> None:
    """Raise `IdentifiabilityError` naming the parameters the data do not excite or determine.

    Parameters
    ----------
    analysis : NumericIdentifiability
        The singular-value analysis of the scaled Jacobian (from `numeric_identifiability`);
        `analysis.not_excited` lists parameters with an all-zero Jacobian column and
        `analysis.weak_directions` the combinations whose relative singular value is below
        `analysis.rtol` (dimensionless).
    where : str
        Prefix of the message naming the caller, e.g. ``"InputErrorEstimator.fit"``.

    Returns
    -------
    None
        Returns only when every parameter is excited and determined.

    Raises
    ------
    IdentifiabilityError
        Naming the unexcited parameters, or each weak combination in words, and the fix
        (``fixed={NAME: VALUE}``, or a richer motion); the argument is marked with
        `physid.errors.arg`, so the command line shows its flag instead.
    """
    if analysis.not_excited:
        raise IdentifiabilityError(
            f"{where}: the data do not excite {_join_words(analysis.not_excited)} at all (the "
            "residuals' sensitivity to it is zero on every sample, e.g. a joint that never "
            f"moves). Fix it with {arg('fixed', '{NAME: VALUE}', cli='NAME=VALUE')} or record "
            "a motion that moves it."
        )
    if analysis.weak_directions:
        texts = "; ".join(c.text for c in analysis.weak_directions)
        first = analysis.weak_directions[0].parameters[-1]
        raise IdentifiabilityError(
            f"{where}: the Jacobian is (numerically) singular: {texts} (relative singular value "
            f"below {analysis.rtol:g}). Hold one parameter of each, e.g. "
            f"{arg('fixed', f'{{{first!r}: VALUE}}', cli=f'{first}=VALUE')}, or excite the "
            "system more."
        )
