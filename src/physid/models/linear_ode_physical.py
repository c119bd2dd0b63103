"""Linear-ODE coefficients as expressions of physical parameters, and the map back.

A coefficient may be an expression of physical parameters (``a = ["k/m", "c/m"]``,
``b = ["1/m"]``). `expression_unit` gives such an expression's SI unit;
`_physical_from_coefficients` (behind `LinearODEModel.physical_from_coefficients`) solves the
expressions for the physical parameters where the map is invertible, and names the combinations
that are identifiable where it is not.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

__all__ = ["PhysicalParameters", "expression_unit"]


@dataclass(frozen=True)
class PhysicalParameters:
    """Physical parameters recovered from estimated linear-ODE coefficients.

    Attributes
    ----------
    values : dict
        Identifiable physical parameter → value (SI).
    stderr : dict or None
        Their standard errors (delta method), None without a coefficient covariance.
    identifiable : tuple of str
    unidentifiable : tuple of str
        Parameters the coefficients do not determine (a scale the data cannot see).
    combinations : dict
        Expression text → value: what the coefficients do determine (``{"k/m": 133.3}``).
    message : str
        One line: what was recovered, or which parameters are not identifiable and the fix.
    """

    values: dict = field(default_factory=dict)
    stderr: dict | None = None
    identifiable: tuple = ()
    unidentifiable: tuple = ()
    combinations: dict = field(default_factory=dict)
    message: str = ""

    def to_dict(self) -> dict:
        """JSON-ready dict of the fields."""
        return {
            "values": dict(self.values),
            "stderr": None if self.stderr is None else dict(self.stderr),
            "identifiable": list(self.identifiable),
            "unidentifiable": list(self.unidentifiable),
            "combinations": dict(self.combinations),
            "message": self.message,
        }


def expression_unit(text: str, units) -> str:
    """SI unit of an expression of parameters with declared units (``""`` when it has none).

    Dimensional analysis by scaling: each base unit (m, kg, s, A, rad) is rescaled in turn and the
    expression's value must scale by an integer power of it, the same for two factors; sums of
    unlike terms, functions of dimensional arguments (``exp(k)``) and parameters without a unit
    give ``""``.

    Parameters
    ----------
    text : str
        The expression (``"k/m"``).
    units : mapping of str to str
        Parameter name -> unit (``{"k": "N/m", "m": "kg"}``); ``"1"`` is dimensionless, ``""``
        unknown.

    Returns
    -------
    str
        The SI unit (``"1/s^2"``), ``"1"`` for a dimensionless expression, ``""`` when unknown.

    Examples
    --------
    >>> expression_unit("k/m", {"k": "N/m", "m": "kg"}), expression_unit("1/m", {"m": "kg"})
    ('1/s^2', '1/kg')
    """
    from ..expressions import evaluate_expression
    from ..units import _canonical, parse_unit

    names = _names_of(text)
    dims = {}
    for n in names:
        unit = str((units or {}).get(n, "") or "")
        if not unit:
            return ""
        try:
            dims[n] = np.array(parse_unit("" if unit == "1" else unit).dimension, dtype=float)
        except InputError:
            return ""
    # arbitrary positive probe values (not the nominal ones: a damping of 0 would hide c)
    probe = {n: 1.0 + 0.37 * (i + 1) for i, n in enumerate(names)}

    def value(scale):
        with np.errstate(all="ignore"):
            try:
                return float(
                    evaluate_expression(
                        text, {n: v * float(np.prod(scale ** dims[n])) for n, v in probe.items()}
                    )
                )
            except (InputError, TypeError, ValueError, ZeroDivisionError):
                return float("nan")

    base = value(np.ones(5))
    if not np.isfinite(base) or base == 0.0:
        return ""
    exponents = []
    for i in range(5):
        powers = []
        for factor in (2.0, 3.0):
            scale = np.ones(5)
            scale[i] = factor
            ratio = value(scale) / base
            if not np.isfinite(ratio) or ratio <= 0:
                return ""
            powers.append(np.log(ratio) / np.log(factor))
        e = round(powers[0])
        if any(abs(p - e) > 1e-6 for p in powers):
            return ""
        exponents.append(int(e))
    return _canonical(tuple(exponents)) or "1"


def _names_of(text: str) -> tuple[str, ...]:
    from ..expressions import expression_names

    names, _ = expression_names(text)
    return tuple(n for n in names if n != "pi")


def _expression_parameters(expressions: dict, parameters: dict) -> tuple[str, ...]:
    used: list[str] = []
    for coef, text in expressions.items():
        for name in _names_of(text):
            if name not in parameters:
                raise InputError(
                    f"the expression {text!r} of coefficient {coef!r} uses {name!r}, which is not "
                    f"a parameter; declare it (parameters: {sorted(parameters)})."
                )
            if name not in used:
                used.append(name)
    return tuple(n for n in parameters if n in used)  # in the order they were declared


def _evaluate(text: str, values: dict, coef: str) -> float:
    from ..expressions import evaluate_expression

    with np.errstate(all="ignore"):
        value = float(evaluate_expression(text, {k: float(v) for k, v in values.items()}))
    if not np.isfinite(value):
        raise InputError(
            f"coefficient {coef!r} = {text!r} is {value} at the parameter values "
            f"{ {k: values[k] for k in _names_of(text)} }; give nominal values at which it is "
            "finite (no division by zero)."
        )
    return value


class _Inverse:
    """Sympy forms of the coefficient expressions, their Jacobian and (when found) the inverse."""

    def __init__(self, model, equations: tuple, unknown: tuple):
        import sympy

        from ..expressions import parse_expression

        symbols = {n: sympy.Symbol(n, real=True) for n in model.physical_names}
        self.equations, self.unknown = equations, unknown
        exprs = [parse_expression(model.expressions[c], symbols) for c in equations]
        unknown_syms = [symbols[n] for n in unknown]
        known_syms = [symbols[n] for n in model.physical_names if n not in unknown]
        args = unknown_syms + known_syms
        self.known = tuple(str(s) for s in known_syms)
        self.f = sympy.lambdify(args, exprs, modules="numpy")
        jac = sympy.Matrix(exprs).jacobian(unknown_syms)
        self.jac = sympy.lambdify(args, jac, modules="numpy")
        self.solutions = None
        if len(equations) == len(unknown) <= 6 and all(
            e.is_rational_function(*unknown_syms) for e in exprs
        ):
            rhs = [sympy.Symbol(f"_c{i}") for i in range(len(exprs))]
            try:
                sols = sympy.solve(
                    [e - r for e, r in zip(exprs, rhs, strict=True)], unknown_syms, dict=True
                )
            except (NotImplementedError, ValueError, TypeError):  # pragma: no cover - sympy
                sols = []
            self.solutions = [
                sympy.lambdify(rhs + known_syms, [sol.get(s, s) for s in unknown_syms])
                for sol in sols
                if all(s in sol for s in unknown_syms)
            ]


def _physical_from_coefficients(model, coefficients, covariance):
    """`LinearODEModel.physical_from_coefficients` of ``model`` (see there)."""
    order, given = _given_coefficients(model, coefficients)
    unknown = tuple(p for p in model.physical_unknown if p != model.output_offset)
    equations = tuple(
        c
        for c in model.expressions
        if c in given and set(_names_of(model.expressions[c])) & set(unknown)
    )
    combos = {model.expressions[c]: given[c] for c in equations}
    if not model.expressions or not unknown or not equations:
        return PhysicalParameters(
            combinations=combos,
            message="the model's coefficients are its parameters (no physical expressions)"
            if not model.expressions
            else "no estimated coefficient involves a physical parameter to identify",
        )
    bad_values = {k: v for k, v in given.items() if not np.isfinite(v)}
    if bad_values:
        return PhysicalParameters(
            combinations=combos,
            unidentifiable=unknown,
            message=f"the coefficients {bad_values} are not finite; no physical parameters.",
        )
    key = (equations, unknown)
    if model._inverse is None or (model._inverse.equations, model._inverse.unknown) != key:
        model._inverse = _Inverse(model, equations, unknown)
    inv = model._inverse
    nominal = np.array([model._nominal[p] for p in unknown])
    known = [model._nominal[p] for p in inv.known]
    jac0 = np.atleast_2d(np.asarray(inv.jac(*nominal, *known), dtype=float))
    sv = np.linalg.svd(jac0, compute_uv=False)
    rank = int(np.sum(sv > 1e-9 * max(sv.max(), 1e-300)))
    if rank < len(unknown):
        words = ", ".join(f"{t} = {v:.6g}" for t, v in combos.items())
        return PhysicalParameters(
            unidentifiable=unknown,
            combinations=combos,
            message=(
                f"{', '.join(unknown)} are not identifiable from the coefficients: only "
                f"{len(combos)} combination{'s are' if len(combos) > 1 else ' is'} identifiable, "
                f"{', '.join(combos)} ({words}); the input carries no scale. "
                'Measure the input in physical units (a force: b = ["1/m"]) or fix '
                f"{len(unknown) - rank} of them (identify = false)."
            ),
        )
    target = np.array([given[c] for c in equations])
    solution = _solve_physical(inv, target, known, nominal)
    if solution is None:
        return PhysicalParameters(
            unidentifiable=unknown,
            combinations=combos,
            message="no physical parameters reproduce the estimated coefficients; check the "
            "expressions and the estimates.",
        )
    values = dict(zip(unknown, solution.tolist(), strict=True))
    stderr = None
    if covariance is not None:
        stderr = _physical_stderr(inv, solution, known, covariance, order, equations, unknown)
    return PhysicalParameters(
        values=values,
        stderr=stderr,
        identifiable=unknown,
        combinations=combos,
        message=f"{', '.join(unknown)} recovered from {', '.join(equations)}",
    )


def _given_coefficients(model, coefficients) -> tuple[list, dict]:
    """The coefficient names in the order given and their values as floats, checked."""
    if not isinstance(coefficients, dict):
        try:
            coefficients = dict(coefficients)
        except (TypeError, ValueError):
            raise InputError(
                f"coefficients must be a mapping name -> value; got {type(coefficients).__name__}."
            ) from None
    order = list(coefficients)
    # an estimated output offset is passed through (a result's parameters hold it; it maps to
    # no physical parameter of the ODE), keeping the covariance's order
    bad = [n for n in order if n not in model.coefficient_names and n != model.output_offset]
    if bad:
        raise InputError(
            f"coefficients has unknown name(s) {bad}; the model's coefficients are "
            f"{list(model.coefficient_names)}."
        )
    given = {}
    for n in order:
        try:
            given[n] = float(coefficients[n])
        except (TypeError, ValueError):
            raise InputError(
                f"coefficients[{n!r}] must be a number; got {coefficients[n]!r}."
            ) from None
    return order, given


def _solve_physical(inv, target, known, nominal):
    """The physical parameters that reproduce ``target``: the closed-form solution nearest the
    nominal values, else least squares from them; None when neither fits."""
    solution = None
    for sol in inv.solutions or ():
        with np.errstate(all="ignore"):
            cand = np.asarray(sol(*target, *known), dtype=complex).reshape(-1)
        if np.all(np.isfinite(cand)) and np.all(
            np.abs(cand.imag) <= 1e-12 * (1 + np.abs(cand.real))
        ):
            cand = cand.real
            if solution is None or np.linalg.norm(
                (cand - nominal) / (np.abs(nominal) + 1e-300)
            ) < np.linalg.norm((solution - nominal) / (np.abs(nominal) + 1e-300)):
                solution = cand
    if solution is None:  # no closed form: least squares from the nominal values
        from scipy.optimize import least_squares

        def residual(p):
            return (np.asarray(inv.f(*p, *known), dtype=float) - target) / (np.abs(target) + 1e-300)

        fit = least_squares(residual, nominal, x_scale="jac", xtol=1e-15, ftol=1e-15, gtol=1e-15)
        solution = fit.x if fit.success and np.max(np.abs(fit.fun)) < 1e-8 else None
    return solution


def _physical_stderr(inv, solution, known, covariance, order, equations, unknown) -> dict:
    """Standard errors of the physical parameters by the delta method, σ_p = sqrt(diag(J⁺ Σ J⁺ᵀ))."""
    cov = np.asarray(covariance, dtype=float)
    if cov.shape != (len(order), len(order)):
        history = (
            " (a covariance history, one matrix per sample: pass the final covariance, "
            "result.final_covariance)"
            if cov.ndim == 3 and cov.shape[1:] == (len(order), len(order))
            else ""
        )
        raise InputError(
            f"covariance must be ({len(order)}, {len(order)}), ordered like the coefficients "
            f"{order}; got shape {cov.shape}{history}."
        )
    if not np.all(np.isfinite(cov)):
        raise InputError("covariance must be finite (no NaN or inf entries).")
    idx = [order.index(c) for c in equations]
    jac = np.atleast_2d(np.asarray(inv.jac(*solution, *known), dtype=float))
    pinv = np.linalg.pinv(jac)  # dp = J⁺ dc (J has full column rank here)
    cov_p = pinv @ cov[np.ix_(idx, idx)] @ pinv.T
    return dict(zip(unknown, np.sqrt(np.clip(np.diag(cov_p), 0, None)).tolist(), strict=True))
