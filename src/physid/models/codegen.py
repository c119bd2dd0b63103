"""sympy expressions → Python source of fast numeric functions (common-subexpression eliminated).

Two flavours of generated code:

* **vectorised** (`vector_function_source`, `SharedExpressions.vector_function`): every input
  symbol is bound to a 1-D numpy array (one value per sample) or a scalar; output i becomes row i
  of an ``(n_outputs, n)`` array. No Python loop over samples.
* **scalar** (`SharedExpressions.scalar_lines_split`, `cholesky_solve_lines`): plain Python
  floats and the ``math`` module, for the single-state right-hand sides that ODE integrators
  call thousands of times; the overhead of a numpy call (~1 µs) would dominate there.

A C back end (`c_pd_rhs_source`; `build_shared_library` compiles any C source once with the
system's compiler and loads it with ctypes) serves the closed-loop simulation of symbolic chains;
rigid-body chains use the fixed generic kernel ``models/c/chain_kernel.c`` built the same way.

The generated *source text* is what the on-disk cache stores (`source_to_function` turns it back
into a function with ``compile`` + ``exec``), so a warm load never imports sympy.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

__all__ = [
    "vector_function_source",
    "source_to_function",
    "cholesky_solve_lines",
    "VECTOR_NAMESPACE",
    "SharedExpressions",
    "SCALAR_NAMESPACE",
    "compiler",
    "build_shared_library",
    "c_pd_rhs_source",
]


def _scalar_sign(x: float) -> float:
    """sign(x) for Python floats: −1, 0 or +1 (as numpy.sign)."""
    return (x > 0) - (x < 0)


#: Names the vectorised sources may use (numpy ufuncs by their short names).
VECTOR_NAMESPACE = {
    name: getattr(np, name)
    for name in (
        "sin",
        "cos",
        "tan",
        "arcsin",
        "arccos",
        "arctan",
        "arctan2",
        "sinh",
        "cosh",
        "tanh",
        "exp",
        "log",
        "sqrt",
        "abs",
        "sign",
        "pi",
        "empty",
        "zeros",
        "float64",
        "hypot",
    )
}
VECTOR_NAMESPACE.update(numpy=np, select=np.select, amax=np.amax, amin=np.amin)

#: Names the scalar sources may use (the math module, and sign for Python floats).
SCALAR_NAMESPACE = {name: getattr(math, name) for name in dir(math) if not name.startswith("_")}
SCALAR_NAMESPACE.update(sign=_scalar_sign, abs=abs)


@functools.lru_cache(maxsize=1)
def _printers():
    from sympy.printing.numpy import NumPyPrinter
    from sympy.printing.pycode import PythonCodePrinter

    class _VectorPrinter(NumPyPrinter):
        def _print_sign(self, expr):  # numpy.sign, not sympy's piecewise default
            return f"sign({self._print(expr.args[0])})"

    class _ScalarPrinter(PythonCodePrinter):
        def _print_sign(self, expr):
            return f"sign({self._print(expr.args[0])})"

    settings = {"fully_qualified_modules": False}
    return _VectorPrinter(settings), _ScalarPrinter(settings)


def _cse(exprs):
    import sympy as sp

    symbols = sp.numbered_symbols("_x")
    return sp.cse(list(exprs), symbols=symbols, optimizations=None, order="none")


def vector_function_source(
    name: str,
    arg_groups: Sequence[tuple[str, Sequence]],
    outputs: Sequence,
    *,
    docstring: str = "",
) -> str:
    """Source of ``def name(<group names>..., n)`` returning a ``(len(outputs), n)`` array.

    Row i holds output i for every sample (rows are contiguous, so each write is one fast
    vectorised assignment).

    Parameters
    ----------
    name : str
        Function name.
    arg_groups : sequence of (str, sequence of sympy.Symbol)
        Each group becomes one argument: a sequence (tuple/list) whose entries are unpacked into
        the group's symbols. Entries may be 1-D arrays of length ``n`` or scalars.
    outputs : sequence of sympy.Expr
        One expression per output column. Exact zeros are skipped (the array starts at zero).
    """
    import sympy as sp

    vec, _ = _printers()
    outputs = [sp.sympify(e, strict=True) for e in outputs]
    replacements, reduced = _cse(outputs)
    lines = [f"def {name}({', '.join(g for g, _ in arg_groups)}, n):"]
    if docstring:
        lines.append(f"    {docstring!r}")
    for group, syms in arg_groups:
        syms = list(syms)
        if syms:
            lines.append(f"    {', '.join(str(s) for s in syms)}, = {group}")
    for sym, expr in replacements:
        lines.append(f"    {sym} = {vec.doprint(expr)}")
    lines.append(f"    out = zeros(({len(outputs)}, n))")
    for i, expr in enumerate(reduced):
        if expr == 0:
            continue
        lines.append(f"    out[{i}] = {vec.doprint(expr)}")
    lines.append("    return out")
    return "\n".join(lines) + "\n"


def cholesky_solve_lines(
    n: int, matrix: str, rhs: str, result: str, zero: set | None = None
) -> list[str]:
    """Unrolled Cholesky solve ``M x = b`` for a symmetric positive-definite ``n × n`` matrix.

    The matrix entries must be bound to names ``{matrix}{i}_{j}`` (i ≥ j, lower triangle) and
    the right-hand side to ``{rhs}{i}``; the solution is bound to ``{result}{i}``. Entries listed
    in ``zero`` (pairs ``(i, j)``) are structurally zero and skipped, so a diagonal matrix costs
    ``n`` divisions. Cholesky (M = L Lᵀ) rather than Gaussian elimination: M is symmetric
    positive definite for positive masses, and the factorisation needs no pivoting.
    """
    zero = zero or set()
    if all((i, j) in zero for i in range(n) for j in range(i)):
        return [f"{result}{i} = {rhs}{i} / {matrix}{i}_{i}" for i in range(n)]
    lines = []
    lz = set()  # structurally-zero entries of L
    for j in range(n):
        # L_jj = sqrt(M_jj - Σ_k<j L_jk²)
        terms = [f"L{j}_{k}*L{j}_{k}" for k in range(j) if (j, k) not in lz]
        lines.append(f"L{j}_{j} = sqrt({matrix}{j}_{j}{''.join(' - ' + t for t in terms)})")
        for i in range(j + 1, n):
            # L_ij = (M_ij - Σ_k<j L_ik L_jk) / L_jj
            terms = [
                f"L{i}_{k}*L{j}_{k}" for k in range(j) if (i, k) not in lz and (j, k) not in lz
            ]
            if (i, j) in zero and not terms:
                lz.add((i, j))
                continue
            head = "0.0" if (i, j) in zero else f"{matrix}{i}_{j}"
            lines.append(f"L{i}_{j} = ({head}{''.join(' - ' + t for t in terms)}) / L{j}_{j}")
    # forward substitution L z = b
    for i in range(n):
        terms = [f"L{i}_{k}*z{k}" for k in range(i) if (i, k) not in lz]
        lines.append(f"z{i} = ({rhs}{i}{''.join(' - ' + t for t in terms)}) / L{i}_{i}")
    # back substitution Lᵀ x = z
    for i in reversed(range(n)):
        terms = [f"L{k}_{i}*{result}{k}" for k in range(i + 1, n) if (k, i) not in lz]
        lines.append(f"{result}{i} = (z{i}{''.join(' - ' + t for t in terms)}) / L{i}_{i}")
    return lines


def source_to_function(source: str, name: str, *, scalar: bool = False):
    """Compile generated ``source`` and return the function called ``name``."""
    namespace = dict(SCALAR_NAMESPACE if scalar else VECTOR_NAMESPACE)
    code = compile(source, f"<physid-generated {name}>", "exec")
    exec(code, namespace)  # noqa: S102 - our own generated source (or our own cache of it)
    return namespace[name]


def _topological(lines):
    """Order ``(symbol, expr)`` lines so every symbol is defined before it is used (stable)."""
    defined = {sym for sym, _ in lines}
    done: set = set()
    out = []
    pending = list(lines)
    while pending:
        rest = []
        for sym, expr in pending:
            if all(s in done or s not in defined for s in expr.free_symbols):
                out.append((sym, expr))
                done.add(sym)
            else:
                rest.append((sym, expr))
        if len(rest) == len(pending):  # pragma: no cover - would be a cycle
            raise RuntimeError("cyclic definitions in generated code")
        pending = rest
    return out


def angle_sum_definitions(exprs, angles):
    """Replace sin/cos of sums of joint angles by symbols defined through angle addition.

    cos(a + b) = cos a cos b − sin a sin b and sin(a + b) = sin a cos b + cos a sin b, built up
    one angle at a time and shared between sums with a common prefix. A numpy ``cos`` over an
    array costs tens of multiplications, so for vectorised code this is several times cheaper;
    for scalar code it is about even. Arguments must be sums of ±1 times the ``angles``.

    Returns (new expressions, [(symbol, definition), ...]).
    """
    import sympy as sp

    index = {a: i for i, a in enumerate(angles)}

    def key_of(arg):
        key = [0] * len(angles)
        for term in sp.Add.make_args(arg):
            c, rest = term.as_coeff_Mul()
            if rest not in index or c not in (1, -1):
                return None
            key[index[rest]] += int(c)
        if sum(abs(k) for k in key) < 2 or any(abs(k) > 1 for k in key):
            return None
        return tuple(key)

    table: dict = {}  # key -> (cos symbol, sin symbol)
    defs: list = []

    def cs(key):
        nz = [i for i, k in enumerate(key) if k]
        if len(nz) == 1:
            i = nz[0]
            a = angles[i] * key[i]
            return sp.cos(a), sp.sin(a)
        if key in table:
            return table[key]
        last = nz[-1]
        head = tuple(k if i != last else 0 for i, k in enumerate(key))
        ch, sh = cs(head)
        ct, st = cs(tuple(key[i] if i == last else 0 for i in range(len(key))))
        name = "".join(("p" if k > 0 else "m") + str(i) for i, k in enumerate(key) if k)
        c_sym, s_sym = sp.Symbol(f"_c{name}"), sp.Symbol(f"_s{name}")
        defs.append((c_sym, ch * ct - sh * st))  # cos(a + b) = cos a cos b − sin a sin b
        defs.append((s_sym, sh * ct + ch * st))  # sin(a + b) = sin a cos b + cos a sin b
        table[key] = (c_sym, s_sym)
        return table[key]

    mapping = {}
    for e in exprs:
        for f in e.atoms(sp.sin, sp.cos):
            key = key_of(f.args[0])
            if key is not None:
                c_sym, s_sym = cs(key)
                mapping[f] = c_sym if isinstance(f, sp.cos) else s_sym
    return [e.xreplace(mapping) for e in exprs], defs


class SharedExpressions:
    """One common-subexpression elimination over many outputs, reused by several functions.

    ``reduced[i]`` is output i written in the cse symbols ``_x0, _x1, ...``; each generated
    function prints only the replacement lines its outputs need (found by walking dependencies),
    so the mass-matrix function never computes velocity terms, yet the expensive ``cse`` and
    printing run once.
    """

    def __init__(self, exprs, angles: Sequence = ()):
        import sympy as sp

        exprs = [sp.sympify(e, strict=True) for e in exprs]
        defs: list = []
        if angles:
            exprs, defs = angle_sum_definitions(exprs, angles)
        n_out = len(exprs)
        replacements, reduced = _cse(exprs + [e for _, e in defs])
        self.reduced = reduced[:n_out]
        # angle-sum definitions become ordinary lines; sort all lines by dependency
        lines = list(replacements) + [
            (sym, e) for (sym, _), e in zip(defs, reduced[n_out:], strict=False)
        ]
        self.replacements = _topological(lines)
        self._index = {sym: i for i, (sym, _) in enumerate(self.replacements)}
        self._deps = [
            [self._index[s] for s in expr.free_symbols if s in self._index]
            for _, expr in self.replacements
        ]
        self._printed: dict = {}

    def _needed(self, exprs) -> list[int]:
        stack = [self._index[s] for e in exprs for s in e.free_symbols if s in self._index]
        seen: set = set()
        while stack:
            i = stack.pop()
            if i in seen:
                continue
            seen.add(i)
            stack.extend(self._deps[i])
        return sorted(seen)

    def _line(self, i: int, scalar: bool) -> str:
        key = (i, scalar)
        if key not in self._printed:
            vec, sca = _printers()
            sym, expr = self.replacements[i]
            self._printed[key] = f"{sym} = {(sca if scalar else vec).doprint(expr)}"
        return self._printed[key]

    def vector_function(self, name: str, arg_groups, outputs) -> str:
        """Like `vector_function_source`, with ``outputs`` written in the reduced expressions."""
        import sympy as sp

        vec, _ = _printers()
        outputs = [sp.sympify(e, strict=True) for e in outputs]
        lines = [f"def {name}({', '.join(g for g, _ in arg_groups)}, n):"]
        for group, syms in arg_groups:
            syms = list(syms)
            if syms:
                lines.append(f"    {', '.join(str(s) for s in syms)}, = {group}")
        lines += [f"    {self._line(i, False)}" for i in self._needed(outputs)]
        lines.append(f"    out = zeros(({len(outputs)}, n))")
        for i, expr in enumerate(outputs):
            if expr != 0:
                lines.append(f"    out[{i}] = {vec.doprint(expr)}")
        lines.append("    return out")
        return "\n".join(lines) + "\n"

    def scalar_lines_split(self, assignments, constant_symbols) -> tuple[list[str], list[str]]:
        """Scalar ``target = expression`` lines for reduced expressions, with what they need, split
        into (lines depending only on ``constant_symbols``, the rest).

        The constant part (typically parameter-only products such as ``m2*l2**2``) can be
        evaluated once when parameters are bound, not at every call. Inside the remaining lines,
        the constant terms of a sum and the constant factors of a product are hoisted too
        (``(13/12)*m1*l1**2 + m2*l1**2 + f(q)`` → ``_k0 + f(q)`` with ``_k0`` precomputed).
        """
        import sympy as sp

        _, sca = _printers()
        const = set(constant_symbols)
        exprs = [sp.sympify(e, strict=True) for _, e in assignments]
        needed = self._needed(exprs)
        const_rep: set = set()
        head, body = [], []
        hoisted: dict = {}

        def is_const(e):
            return all(s in const or s in const_rep for s in e.free_symbols)

        def hoist(expr):
            if not isinstance(expr, (sp.Add, sp.Mul)):
                return expr
            parts = [a for a in expr.args if is_const(a)]
            worth = len(parts) >= 2 or (
                len(parts) == 1 and not (parts[0].is_Symbol or parts[0].is_Number)
            )
            if not worth or len(parts) == len(expr.args):
                return expr
            part = expr.func(*parts)
            if part not in hoisted:
                name = sp.Symbol(f"_k{len(hoisted)}")
                hoisted[part] = name
                head.append(f"{name} = {sca.doprint(part)}")
            rest = [a for a in expr.args if not is_const(a)]
            return expr.func(hoisted[part], *rest)

        for i in needed:
            sym, expr = self.replacements[i]
            if is_const(expr):
                const_rep.add(sym)
                head.append(self._line(i, True))
            else:
                body.append(f"{sym} = {sca.doprint(hoist(expr))}")
        for (t, _), e in zip(assignments, exprs, strict=False):
            if is_const(e):
                head.append(f"{t} = {sca.doprint(e)}")
            else:
                body.append(f"{t} = {sca.doprint(hoist(e))}")
        return head, body


# ---------------------------------------------------------------------------------------------
# C back end: compile a source once (cc + ctypes), cache the shared library by content
# ---------------------------------------------------------------------------------------------

_LIBRARIES: dict = {}


def compiler() -> str | None:
    """Path of the C compiler used ($CC, else cc, gcc or clang on PATH), or None."""
    import os
    import shutil

    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name:
            path = shutil.which(name)
            if path:
                return path
    return None


def build_shared_library(source, tag: str, *, key: str | None = None, cc="auto"):
    """Compile C ``source`` into a shared library (cached on disk by content) and load it.

    Parameters
    ----------
    source : str or callable
        C99 source, or a function returning it (called only when the library must be built).
    tag : str
        Short name used in the cached file's name (``tag-<hash>.so``).
    key : str, optional
        Cache key; default the hash of the source (then ``source`` must be a string).
    cc : str or None
        The compiler ("auto": `compiler`); None: use a cached library only.

    Returns
    -------
    ctypes.CDLL or None
        None when no compiler works or the build fails (callers fall back to numpy/Python).

    Notes
    -----
    Loading a library runs its code, so a cached library is loaded only from a trusted cache
    folder (`physid._paths.trusted_cache`), only if the file is the user's own and not writable
    by others, and only if its bytes match the HMAC-SHA256 written beside it
    (``tag-<hash>.so.hmac``, keyed with the folder's per-user secret); otherwise it is built
    again, never loaded. With an untrusted folder the library is built in a private temporary
    folder, loaded from there and the folder removed.
    """
    import hashlib
    import sys

    from .._paths import trusted_cache

    if key is None:
        text = source + sys.platform + str(sys.version_info[:2])
        key = hashlib.sha256(text.encode()).hexdigest()[:32]
    trusted = trusted_cache(create=cc is not None)
    memo = (str(trusted[0]) if trusted else None, tag, key)
    if memo in _LIBRARIES:
        return _LIBRARIES[memo]
    if trusted is None:
        lib = _build_private(source, tag, cc)
    else:
        lib = _load_cached(trusted, source, tag, key, cc)
    if lib is not None:
        _LIBRARIES[memo] = lib
    return lib


def _library_mac(secret: bytes, name: str, data: bytes) -> str:
    from .._paths import cache_mac

    return cache_mac(secret, b"physid-shared-library-1", name.encode(), data)


def _compile(source, tag: str, cc, folder):
    """Compile into ``folder``; the path of the library, or None (no compiler, failed build)."""
    import subprocess
    from pathlib import Path

    cc = compiler() if cc == "auto" else cc
    if cc is None:
        return None
    if callable(source):
        try:
            source = source()
        except (AttributeError, TypeError, ValueError, NotImplementedError):
            return None  # nothing printable as C
    src = Path(folder) / f"{tag}.c"
    src.write_text(source, encoding="utf-8")
    out = Path(folder) / f"{tag}.so"
    proc = subprocess.run(
        # relative names, run in the build folder: the same bytes from every build
        [cc, "-O3", "-shared", "-fPIC", "-o", out.name, src.name, "-lm"],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=120,
    )
    return out if proc.returncode == 0 else None


def _load(path):
    import ctypes

    try:
        return ctypes.CDLL(str(path))
    except OSError:
        return None


def _build_private(source, tag: str, cc):
    """Build in a private temporary folder (mode 0700), load, remove the folder."""
    import shutil
    import subprocess
    import tempfile

    if cc is None:
        return None
    folder = tempfile.mkdtemp(prefix="physid-build-")
    try:
        out = _compile(source, tag, cc, folder)
        return None if out is None else _load(out)  # a loaded library outlives its file
    except (OSError, subprocess.SubprocessError):
        return None
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _load_bytes(data: bytes, name: str):
    """Load exactly ``data`` (bytes already verified): a copy in a fresh private temporary
    folder (mode 0700, only this user can write it) is loaded and removed with its folder, so
    the library loaded is the one checked, not whatever the cache path holds by then."""
    import os
    import shutil
    import tempfile

    folder = tempfile.mkdtemp(prefix="physid-load-")
    try:
        copy = os.path.join(folder, name)
        fd = os.open(copy, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o700)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        return _load(copy)  # a loaded library outlives its file
    except OSError:
        return None
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _load_cached(trusted, source, tag: str, key: str, cc):
    """Load ``tag-key.so`` from the trusted cache if its HMAC verifies, else build it there.

    The bytes verified are the bytes loaded (`_load_bytes`): the cache file is never loaded by
    its path, which another process could change between the check and the load.
    """
    import os
    import subprocess
    import tempfile
    from pathlib import Path

    from .._paths import atomic_write, read_private, same_mac

    folder, secret = trusted
    name = f"{tag}-{key}.so"
    lib_path = folder / name
    mac_path = folder / f"{name}.hmac"

    def verified() -> bytes | None:  # the library's bytes, if they match the MAC beside it
        data, mac = read_private(lib_path), read_private(mac_path)
        if data is None or mac is None:
            return None
        ok = same_mac(_library_mac(secret, name, data), mac.decode("ascii", "replace").strip())
        return data if ok else None

    data = verified()
    if data is None:  # absent, or altered since it was built: build it again, never load it
        if cc is None:
            return None
        try:
            with tempfile.TemporaryDirectory(dir=folder) as tmp:
                out = _compile(source, tag, cc, tmp)
                if out is None:
                    return None
                os.chmod(out, 0o700)
                mac = _library_mac(secret, name, Path(out).read_bytes())
                os.replace(out, lib_path)  # atomic: a reader never sees half a library
                atomic_write(mac_path, lambda fh: fh.write(mac + "\n"), mode=0o600)
        except (OSError, subprocess.SubprocessError):
            return None
        data = verified()
        if data is None:  # another process replaced it meanwhile: load nothing unverified
            return None
    return _load_bytes(data, name)


def c_pd_rhs_source(eqs) -> str:
    """C back end of the symbolic chains: ``void pd_rhs(double *ctx)`` from their equations.

    Long by design: it prints one C function top to bottom (unpacking, spline, PD law, M and h,
    Cholesky solve), and each block is a few lines of the template.

    The same common-subexpression-eliminated M (lower triangle) and h = c + G + F as the numpy
    back end, printed with `sympy.printing.c.ccode`, with the PD law τ = Kp (r − q) − Kd q̇,
    the reference's cubic spline (Horner) and a Cholesky solve of M q̈ = τ − h in one function.

    ``ctx`` layout (doubles): ``[t, y (2n), ẏ (2n, written), t0, h, n_int, use_spline, θ (n_p),
    Kp (n), Kd (n), r_first (n), r_last (n), r_now (n), spline coefficients (n_int × n × 4,
    c3..c0 per joint)]``. With ``use_spline = 0`` the reference is read from ``r_now`` (filled by
    the caller). One pointer argument keeps the ctypes call cheap (~1 µs).

    Parameters
    ----------
    eqs : physid.models.lagrange.ChainEquations
        From ``ChainModel.symbolic_equations()``.

    Returns
    -------
    str
        C99 source.
    """
    import sympy as sp
    from sympy.printing.c import ccode

    n = len(eqs.q)
    n_p = len(eqs.theta)
    lower = [(i, j) for i in range(n) for j in range(i + 1)]
    h_exprs = [eqs.coriolis[i] + eqs.gravity[i] + eqs.friction[i] for i in range(n)]
    exprs = [eqs.mass_matrix[i, j] for i, j in lower] + h_exprs
    replacements, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("x"))
    names = {}
    for i in range(n):
        names[eqs.q[i]] = sp.Symbol(f"y[{i}]")
        names[eqs.qd[i]] = sp.Symbol(f"y[{n + i}]")
    for k, th in enumerate(eqs.theta):
        names[th] = sp.Symbol(f"TH[{k}]")

    def c(expr) -> str:
        return ccode(sp.sympify(expr, strict=True).xreplace(names), standard="c99")

    lines = [
        "#include <math.h>",
        f"#define NJ {n}",
        f"#define NP {n_p}",
        "void pd_rhs(double *ctx) {",
        "    const double t = ctx[0];",
        "    const double *y = ctx + 1;",
        "    double *dy = ctx + 1 + 2 * NJ;",
        "    const double *S = ctx + 1 + 4 * NJ;",
        "    const double t0 = S[0], hk = S[1];",
        "    const long n_int = (long)S[2];",
        "    const int use_spline = S[3] != 0.0;",
        "    const double *TH = S + 4;",
        "    const double *KP = TH + NP, *KD = KP + NJ, *RF = KD + NJ, *RL = RF + NJ, *RN = "
        "RL + NJ;",
        "    const double *COEF = RN + NJ;",
        "    double r[NJ], M[NJ][NJ], b[NJ], L[NJ][NJ], z[NJ];",
        "    int i, j, k;",
        "    if (!use_spline) { for (j = 0; j < NJ; j++) r[j] = RN[j]; }",
        "    else if (n_int == 0 || t <= t0) { for (j = 0; j < NJ; j++) r[j] = RF[j]; }",
        "    else if (t >= t0 + n_int * hk) { for (j = 0; j < NJ; j++) r[j] = RL[j]; }",
        "    else {",
        "        long iv = (long)((t - t0) / hk);",
        "        if (iv >= n_int) iv = n_int - 1;",
        "        const double s = t - (t0 + iv * hk);",
        "        for (j = 0; j < NJ; j++) {",
        "            const double *cc = COEF + (iv * NJ + j) * 4;",
        "            r[j] = ((cc[0] * s + cc[1]) * s + cc[2]) * s + cc[3];  /* Horner */",
        "        }",
        "    }",
    ]
    for sym, expr in replacements:
        lines.append(f"    const double {sym} = {c(expr)};")
    for r, (i, j) in enumerate(lower):
        lines.append(f"    M[{i}][{j}] = {c(reduced[r])};")
    for i in range(n):
        h = c(reduced[len(lower) + i])
        # b = τ − h with the PD law τ = Kp (r − q) − Kd q̇
        lines.append(f"    b[{i}] = KP[{i}] * (r[{i}] - y[{i}]) - KD[{i}] * y[{n + i}] - ({h});")
    lines += [
        "    /* Cholesky M = L Lᵀ (lower triangle of M is filled), then L z = b, Lᵀ q̈ = z */",
        "    for (j = 0; j < NJ; j++) {",
        "        double d = M[j][j];",
        "        for (k = 0; k < j; k++) d -= L[j][k] * L[j][k];",
        "        L[j][j] = sqrt(d);",
        "        for (i = j + 1; i < NJ; i++) {",
        "            double s = M[i][j];",
        "            for (k = 0; k < j; k++) s -= L[i][k] * L[j][k];",
        "            L[i][j] = s / L[j][j];",
        "        }",
        "    }",
        "    for (i = 0; i < NJ; i++) {",
        "        double s = b[i];",
        "        for (k = 0; k < i; k++) s -= L[i][k] * z[k];",
        "        z[i] = s / L[i][i];",
        "    }",
        "    for (i = NJ - 1; i >= 0; i--) {",
        "        double s = z[i];",
        "        for (k = i + 1; k < NJ; k++) s -= L[k][i] * dy[NJ + k];",
        "        dy[NJ + i] = s / L[i][i];",
        "    }",
        "    for (i = 0; i < NJ; i++) dy[i] = y[NJ + i];",
        "}",
    ]
    return "\n".join(lines) + "\n"
