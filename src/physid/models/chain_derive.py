"""Deriving a chain's equations of motion (the cold path, with sympy) and the generated sources.

`_derive` derives the equations of a `ChainSpec` and generates the source of every numeric
function; `_derive_jacobian` and `_derive_regressor` the fallback ∂τ/∂θ and the
linear-in-parameters form; `_scalar_factory_source` writes the factories of the single-state
right-hand sides. `_with_progress` says on stderr when a derivation is slow, and `_valid_entry`
checks a cache entry against its spec.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import IdentifiabilityError
from .codegen import cholesky_solve_lines, source_to_function
from .spec_types import ChainSpec


def on_symbolic_chain(fn, spec: ChainSpec, sym: dict):
    """``fn`` (`lagrange.derive_chain_equations` or `lagrange.regressor_columns`) applied to the
    symbolic chain ``sym = symbolic_chain(spec)``: the one place that spells their arguments."""
    return fn(
        sym["transforms"],
        sym["masses"],
        sym["rotor_inertias"],
        sym["viscous"],
        sym["coulomb"],
        spec.gravity,
        sym["q"],
        sym["qd"],
        sym["qdd"],
        sym["theta"],
        kinetic=spec.kinetic,
        axis_static=sym["axis_static"],
    )


def _derive(spec: ChainSpec) -> dict:
    """Derive the equations of `spec` and generate the source of every numeric function.

    One common-subexpression elimination over [M (lower triangle), c, G, F] feeds every
    generated function: mass, gravity, bias (c + G + F), inverse dynamics (Σ_j M_ij q̈_j + h_i,
    assembled in the generated code rather than as one huge expression) and the scalar body of
    the single-state right-hand sides.
    """
    import sympy as sp

    from .chain_symbolic import symbolic_chain
    from .codegen import SharedExpressions
    from .lagrange import derive_chain_equations

    sym = symbolic_chain(spec)
    q, qd, qdd, th = sym["q"], sym["qd"], sym["qdd"], sym["theta"]
    n = len(q)
    eqs = on_symbolic_chain(derive_chain_equations, spec, sym)
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
    from .chain_symbolic import symbolic_chain
    from .codegen import vector_function_source
    from .lagrange import derive_chain_equations

    sym = symbolic_chain(spec)
    q, qd, qdd, th = sym["q"], sym["qd"], sym["qdd"], sym["theta"]
    eqs = on_symbolic_chain(derive_chain_equations, spec, sym)
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

    from .chain_symbolic import symbolic_chain
    from .codegen import vector_function_source
    from .lagrange import monomial_name, regressor_columns

    sym = symbolic_chain(spec)
    q, qd, qdd = sym["q"], sym["qd"], sym["qdd"]
    n = len(q)
    try:
        monomials, columns = on_symbolic_chain(regressor_columns, spec, sym)
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
