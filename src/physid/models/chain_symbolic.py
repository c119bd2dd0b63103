"""The symbolic side of a chain specification: its expressions parsed into sympy, its transforms
checked, its constant expressions checked at the nominal values (sympy is imported only here and
in the derivation)."""

from __future__ import annotations

from ..errors import ModelFileError
from .spec_chain import _ATTRIBUTE_UNITS, _DH_UNITS
from .spec_types import _RESERVED_PATTERN, FUNCTION_NAMES, RESERVED_NAMES, ChainSpec

__all__ = [
    "dh_transform",
    "parse_expression",
    "check_transform",
    "check_nominal_values",
    "symbolic_chain",
]


def dh_transform(a, alpha, d, theta):
    """Standard (distal) Denavit–Hartenberg transform T = Rz(θ) Tz(d) Tx(a) Rx(α).

    ::

        ⎡cos θ  −sin θ cos α   sin θ sin α   a cos θ⎤
        ⎢sin θ   cos θ cos α  −cos θ sin α   a sin θ⎥
        ⎢  0        sin α         cos α         d   ⎥
        ⎣  0          0             0           1   ⎦

    With a = 0, α = π/2 this is the paper's T1 and with a = l_k, α = 0 its T2..T4 (Cedro &
    Janecki, section 2), for θ = φ_k.

    Parameters
    ----------
    a : number or sympy expression [m]
        Link length (translation along the new x axis).
    alpha : number or sympy expression [rad]
        Link twist (rotation about the new x axis).
    d : number or sympy expression [m]
        Link offset (translation along the old z axis).
    theta : number or sympy expression [rad]
        Joint angle (rotation about the old z axis), q_k + offset.

    Returns
    -------
    sympy.Matrix, shape (4, 4)
        The homogeneous transform from the link frame to the previous one.

    Examples
    --------
    >>> import sympy as sp
    >>> q, l = sp.symbols("q l")
    >>> dh_transform(l, 0, 0, q)[:2, 3].T
    Matrix([[l*cos(q), l*sin(q)]])
    """
    import sympy as sp

    ct, st = sp.cos(theta), sp.sin(theta)
    ca, sa = sp.cos(alpha), sp.sin(alpha)
    return sp.Matrix(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0, sa, ca, d],
            [0, 0, 0, 1],
        ]
    )


def parse_expression(
    text: str,
    symbols: dict,
    where: str,
    *,
    allowed_hint: str = "",
    unit: str = "",
    variable_hint: str = "",
):
    """Parse one expression string with only ``symbols`` and the standard functions allowed.

    The parsing is `physid.expressions.parse_expression` (a whitelist over Python's syntax tree;
    nothing is evaluated); this wrapper words its errors for model files.

    Parameters
    ----------
    text : str
        The expression, in Python syntax (``"m1*l1**2/12"``, ``"cos(q1)"``).
    symbols : dict of str to sympy.Symbol
        The names the expression may use.
    where : str
        Location for error messages (``"arm.toml, line 7 (joints[1].mass)"``).
    allowed_hint : str
        Appended to the unknown-symbol message (e.g. the declared parameters).
    unit : str
        SI unit of the key (``"kg"`` for a mass), suggested in the "declare it under
        [parameters]" fix when the unknown symbol is the whole expression; empty: none.
    variable_hint : str
        Message used when an unknown symbol is a reserved name (another joint's ``q<k>``,
        ``qd<k>``, ``qdd<k>``, ...), which cannot be declared as a parameter.

    Returns
    -------
    sympy.Expr
        A finite real expression in ``symbols``.

    Raises
    ------
    ModelFileError
        The text does not parse, uses a forbidden construct (strings, attributes, ...), an
        unknown symbol or function, is too large, or is not finite and real.

    Examples
    --------
    >>> import sympy as sp
    >>> m, l = sp.symbols("m l")
    >>> parse_expression("m1*l1**2/12", {"m1": m, "l1": l}, "demo")
    l**2*m/12
    """
    from ..errors import ExpressionError
    from ..expressions import _clip, _clip_names
    from ..expressions import parse_expression as _parse

    try:
        return _real_parts(_parse(text, symbols, source=where))
    except ExpressionError as exc:
        shown = _clip(text)
        if exc.reason == "unknown_function":
            raise ModelFileError(
                f"{where}: unknown function(s) {_clip_names(exc.names)} in {shown}; allowed "
                f"functions: {', '.join(n for n in FUNCTION_NAMES if n != 'pi')}."
            ) from None
        if exc.reason != "unknown_name":
            raise ModelFileError(str(exc)) from None
        unknown = list(exc.names)
    reserved = [u for u in unknown if u in RESERVED_NAMES or _RESERVED_PATTERN.match(u)]
    if reserved:
        fix = variable_hint or (
            "these are reserved names (joint variables q<k>, qd<k>, qdd<k>, tau<k>, functions), "
            "not parameters"
        )
        raise ModelFileError(
            f"{where}: symbol(s) {_clip_names(reserved)} may not appear in {shown}: {fix}."
        )
    # the key's unit fits the symbol only when the symbol is the whole expression
    unit_text = f', unit = "{unit}"' if unit and text.strip() == unknown[0] else ""
    hint = allowed_hint if len(allowed_hint) <= 300 else allowed_hint[:280] + " ..."
    raise ModelFileError(
        f"{where}: unknown symbol(s) {_clip_names(unknown)} in {shown}; declare each under "
        f"[parameters] (e.g. {unknown[0][:40]} = {{ value = 1.0{unit_text} }}){hint}."
    )


def _real_parts(expr):
    """``expr`` with ``re(x)`` → ``x``, ``im(x)`` → 0 and ``conjugate(x)`` → ``x``: every name of a
    model file is real, but sympy's symbols carry no assumptions, so it writes ``abs(exp(m1))`` as
    ``exp(re(m1))``, which the code printers of the derivation cannot print."""
    import sympy as sp

    if not expr.has(sp.re, sp.im, sp.conjugate):
        return expr
    return (
        expr.replace(sp.re, lambda x: x)
        .replace(sp.im, lambda x: 0)
        .replace(sp.conjugate, lambda x: x)
    )


def check_transform(
    T, q_sym, theta_syms, theta_values, where: str, *, joint: int, rng=None
) -> None:
    """Raise `ModelFileError` unless T is a rigid homogeneous transform at random q.

    Checks: bottom row (0, 0, 0, 1) and R Rᵀ = I, det R = +1 for the rotation part, numerically at
    five random joint angles with the parameters at their nominal values.
    """
    import numpy as np
    import sympy as sp

    rng = np.random.default_rng(12345) if rng is None else rng
    f = sp.lambdify([q_sym, *theta_syms], T, modules="numpy")
    for qv in rng.uniform(-np.pi, np.pi, size=5):
        try:
            Tn = np.array(f(qv, *theta_values), dtype=float)
        except (TypeError, ValueError, ZeroDivisionError) as exc:
            raise ModelFileError(
                f"{where}: cannot evaluate the transform numerically ({exc})."
            ) from None
        if not np.all(np.isfinite(Tn)):
            raise ModelFileError(
                f"{where}: the transform is not finite at q{joint} = {qv:.3f} rad."
            )
        if not np.allclose(Tn[3], [0, 0, 0, 1], atol=1e-9):
            raise ModelFileError(
                f"{where}: the bottom row of the transform of joint {joint} must be [0, 0, 0, 1]; "
                f"got {np.round(Tn[3], 6).tolist()} at q{joint} = {qv:.3f} rad."
            )
        R = Tn[:3, :3]
        with np.errstate(all="ignore"):  # entries near 1e308 overflow in R Rᵀ: not a rotation
            err = float(np.abs(R @ R.T - np.eye(3)).max())
            det = float(np.linalg.det(R)) if np.isfinite(err) else float("nan")
        if not err <= 1e-8 or not det > 0:
            raise ModelFileError(
                f"{where}: the rotation part (upper-left 3×3) of the transform of joint {joint} is "
                f"not orthonormal with det +1 (max |R Rᵀ − I| = {err:.3g}, det = "
                f"{det:.4g} at q{joint} = {qv:.3f} rad, nominal parameters). Check "
                f"signs and sin/cos placement; a rotation about z is [[cos(q), -sin(q), 0], "
                f"[sin(q), cos(q), 0], [0, 0, 1]]."
            )


def check_nominal_values(spec: ChainSpec) -> None:
    """Refuse a chain whose constant expressions are not finite and real at the nominal values.

    Evaluates every DH entry, mass, rotor inertia and friction coefficient numerically
    (`physid.expressions.evaluate_expression`, no sympy, so a warm-cache load checks too) with
    the parameters at their nominal values: ``mass = "m1/(l1 - 0.5)"`` with l1 = 0.5 or
    ``rotor_inertia = "sqrt(-m1)"`` is an error naming its line, not a model full of NaN.
    Transforms (functions of q) are checked by `check_transform` during the derivation.

    Parameters
    ----------
    spec : ChainSpec

    Raises
    ------
    ModelFileError
        An expression that does not parse, uses an unknown name, or has no finite real value.
    """
    import numpy as np

    from ..errors import ExpressionError
    from ..expressions import _clip, evaluate_expression

    values = {p.name: p.value for p in spec.parameters}
    shown = ", ".join(f"{k}={v:.6g}" for k, v in list(values.items())[:12])
    for k, joint in enumerate(spec.joints):
        jt_where = joint.where or f"{spec.source} (joints[{k + 1}])"
        items = [(f"{jt_where} dh.{key}", txt) for key, txt in (joint.dh or ())]
        items += [
            (joint.location(attr) if attr in dict(joint.locations) else f"{jt_where} {attr}", txt)
            for attr, txt in (
                ("mass", joint.mass),
                ("rotor_inertia", joint.rotor_inertia),
                ("viscous", joint.viscous),
                ("coulomb", joint.coulomb),
            )
        ]
        for where, txt in items:
            try:
                value = evaluate_expression(txt, values, source=where)
            except ExpressionError:
                continue  # unknown names etc.: parse_expression words these with the model's hints
            if value.ndim != 0 or not np.isfinite(value):
                raise ModelFileError(
                    f"{where}: the expression {_clip(txt)} has no finite real value at the nominal "
                    f"parameter values ({shown}): got {float(value) if value.ndim == 0 else value}. "
                    "Check divisions by a parameter that is zero and square roots or logarithms of "
                    "negative values; give the parameters nominal values where the model is valid."
                )


def symbolic_chain(spec: ChainSpec):
    """Parse and validate a chain spec; return the sympy pieces for the derivation.

    Parameters
    ----------
    spec : ChainSpec

    Returns
    -------
    dict
        ``q, qd, qdd, theta`` (tuples of internal symbols ``_q0``, ``_th0``, ...),
        ``transforms`` (list of 4×4 sympy matrices), ``axis_static``, ``masses``,
        ``rotor_inertias``, ``viscous``, ``coulomb`` (lists of sympy expressions, one per joint).

    Raises
    ------
    ModelFileError
        An expression does not parse or uses an unknown symbol (the message names the line of
        its key), or a transform is not a rigid homogeneous transform.
    """
    import sympy as sp

    n = len(spec.joints)
    # plain symbols (no assumptions): assumption queries dominate sympy's time on big trees
    q = tuple(sp.Symbol(f"_q{i}") for i in range(n))
    qd = tuple(sp.Symbol(f"_qd{i}") for i in range(n))
    qdd = tuple(sp.Symbol(f"_qdd{i}") for i in range(n))
    theta = tuple(sp.Symbol(f"_th{i}") for i in range(len(spec.parameters)))
    param_syms = {p.name: s for p, s in zip(spec.parameters, theta, strict=False)}
    values = [p.value for p in spec.parameters]
    out = {
        "q": q,
        "qd": qd,
        "qdd": qdd,
        "theta": theta,
        "transforms": [],
        "axis_static": [],
        "masses": [],
        "rotor_inertias": [],
        "viscous": [],
        "coulomb": [],
    }
    declared = ", ".join(param_syms) or "none"
    for k, joint in enumerate(spec.joints):
        jt_where = joint.where or f"{spec.source} (joints[{k + 1}])"
        T, static = _joint_transform(joint, k, jt_where, param_syms, q, theta, values, declared)
        out["transforms"].append(T)
        out["axis_static"].append(static)
        hint = f"; declared parameters: {declared}"
        for key, attr in (
            ("masses", "mass"),
            ("rotor_inertias", "rotor_inertia"),
            ("viscous", "viscous"),
            ("coulomb", "coulomb"),
        ):
            out[key].append(
                parse_expression(
                    getattr(joint, attr),
                    param_syms,
                    dict(joint.locations).get(attr, f"{jt_where} {attr}"),
                    allowed_hint=hint,
                    unit=_ATTRIBUTE_UNITS[attr],
                    variable_hint=(
                        f"the {attr} of a joint is a constant; joint variables (q<k>, qd<k>, "
                        "qdd<k>) may not appear in it"
                    ),
                )
            )
    return out


def _joint_transform(joint, k, jt_where, param_syms, q, theta, values, declared):
    """The sympy transform of joint ``k`` (from 0) and its static part (None for a transform)."""
    import sympy as sp

    with_q = dict(param_syms)
    with_q[f"q{k + 1}"] = q[k]
    hint_q = f"; the transform may use the joint variable q{k + 1} and: {declared}"
    hint = f"; declared parameters: {declared}"
    only_own = (
        f"only q{k + 1} of this joint may appear in its transform (joint variables are "
        "reserved names, not parameters)"
    )
    no_variables = (
        f"joint variables may not appear here; the angle q{k + 1} enters through the DH "
        "rotation about z (use offset for a constant angle)"
    )
    if joint.dh is not None:
        dh = {
            key: parse_expression(
                txt,
                param_syms,
                f"{jt_where} dh.{key}",
                allowed_hint=hint,
                unit=_DH_UNITS[key],
                variable_hint=no_variables,
            )
            for key, txt in joint.dh
        }
        T = dh_transform(dh["a"], dh["alpha"], dh["d"], q[k] + dh["offset"])
        static = dh_transform(dh["a"], dh["alpha"], dh["d"], dh["offset"])  # T = Rz(q) S
        return T, static
    rows = [
        [
            parse_expression(
                txt,
                with_q,
                f"{jt_where} transform[{r}][{c}]",
                allowed_hint=hint_q,
                unit="m" if c == 3 and r < 3 else "",  # translation column; rotation: 1
                variable_hint=only_own,
            )
            for c, txt in enumerate(row)
        ]
        for r, row in enumerate(joint.transform)
    ]
    T = sp.Matrix(rows)
    check_transform(T, q[k], theta, values, jt_where, joint=k + 1)
    return T, None
