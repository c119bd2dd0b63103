"""Compiled closed-loop right-hand side: the model's equations as generated C, loaded with ctypes.

Why: a DOP853 run of the paper's experiment calls the right-hand side ~14 000 times. The model's
generated *Python* scalar code costs tens of microseconds a call, more than pinocchio's C++ ABA
behind its Python binding, and the integrator's own overhead is ~8 µs a call. The same sympy
expressions printed as C (`sympy.printing.c.ccode` after common-subexpression elimination), with
the PD law, an unrolled-by-the-compiler Cholesky solve of ``M q̈ = τ − h`` and the reference's
cubic spline in the same C function, cost ~1 µs plus the ctypes call (see
``benchmarks/bench_simulate.py``).

Dependencies: only a C compiler (``cc``/``gcc``/``clang`` on PATH) and the standard library's
ctypes; no Python package. The shared library is built once per model content and cached in the
physid cache folder (``$PHYSID_CACHE_DIR``, else ``~/.cache/physid``). Without a compiler, or if
the build fails, `compiled_pd_rhs` returns None and the caller falls back to the generated Python
code (same equations, slower).
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from .._paths import cache_dir

__all__ = ["compiled_pd_rhs", "compiler", "c_source"]

#: Bump when the generated C changes, so cached libraries are rebuilt.
_GENERATOR_VERSION = "pdrhs-2"
_LIBS: dict[str, ctypes.CDLL] = {}


def compiler() -> str | None:
    """Path of the C compiler used ($CC, else cc, gcc or clang on PATH), or None."""
    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name:
            path = shutil.which(name)
            if path:
                return path
    return None


def c_source(model) -> str:
    """C source of ``void pd_rhs(double *ctx)``: one buffer in, one buffer out.

    ``ctx`` layout (doubles): ``[t, y (2n), ẏ (2n, written), t0, h, n_int, use_spline, θ (n_p),
    Kp (n), Kd (n), r_first (n), r_last (n), r_now (n), spline coefficients (n_int × n × 4,
    c3..c0 per joint)]``. With ``use_spline = 0`` the reference is read from ``r_now`` (filled by
    the caller). One pointer argument keeps the ctypes call cheap (~1 µs).
    """
    import sympy as sp
    from sympy.printing.c import ccode

    eqs = model.symbolic_equations()
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
        return ccode(sp.sympify(expr).xreplace(names), standard="c99")

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


def _library_key(model) -> str:
    content = {
        "generator": _GENERATOR_VERSION,
        "model": getattr(model, "cache_key", "") or repr(getattr(model, "spec", model)),
        "kinetic": getattr(model, "kinetic", None),
        "gravity": list(getattr(model, "gravity", ())),
        "python": list(sys.version_info[:2]),
        "platform": sys.platform,
    }
    return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()[:32]


def _load_library(model) -> ctypes.CDLL | None:
    key = _library_key(model)
    if key in _LIBS:
        return _LIBS[key]
    folder = cache_dir()
    lib_path = folder / f"pdrhs-{key}.so"
    if not lib_path.exists():
        cc = compiler()
        if cc is None:
            return None
        try:
            source = c_source(model)
        except (AttributeError, TypeError, ValueError, NotImplementedError):
            return None  # not a chain model with symbolic equations, or not printable as C
        try:
            folder.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=folder) as tmp:
                src = Path(tmp) / "pdrhs.c"
                src.write_text(source, encoding="utf-8")
                out = Path(tmp) / "pdrhs.so"
                proc = subprocess.run(
                    [cc, "-O2", "-shared", "-fPIC", "-o", str(out), str(src), "-lm"],
                    capture_output=True,
                    text=True,
                    timeout=120,
                )
                if proc.returncode != 0:
                    return None
                os.replace(out, lib_path)  # atomic: a reader never sees half a library
        except (OSError, subprocess.SubprocessError):
            return None
    try:
        lib = ctypes.CDLL(str(lib_path))
    except OSError:
        return None
    fn = lib.pd_rhs
    fn.restype = None
    fn.argtypes = [ctypes.c_void_p]
    _LIBS[key] = lib
    return lib


def compiled_pd_rhs(model, params, kp, kd, reference):
    """``f(t, y) -> ẏ`` of the PD closed loop as compiled C, or None when no compiler works.

    Parameters
    ----------
    model : ChainModel
    params : dict or array, optional
    kp, kd : ndarray (n_joints,)
    reference : ReferenceTrajectory with uniform knots (evaluated in C), or any callable
        ``r(t)`` (evaluated in Python and passed in).
    """
    from .references import ReferenceTrajectory

    lib = _load_library(model)
    if lib is None:
        return None
    n = int(model.n_joints)
    theta = np.asarray(model.parameter_vector(params), dtype=float)
    spline = isinstance(reference, ReferenceTrajectory) and reference.uniform_step is not None
    if spline:
        t0, step = float(reference.t[0]), float(reference.uniform_step)
        coef = np.asarray(reference.coefficients, dtype=float)  # (n_int, n, 4)
        n_int = coef.shape[0]
        first, last = np.asarray(reference.values[0]), np.asarray(reference.values[-1])
    else:
        t0, step, n_int = 0.0, 1.0, 0
        coef = np.zeros(0)
        first = last = np.zeros(n)
    n_y = 2 * n
    ctx = np.concatenate(
        [
            np.zeros(1 + 2 * n_y),  # t, y, ẏ
            [t0, step, float(n_int), 1.0 if spline else 0.0],
            theta,
            kp,
            kd,
            first,
            last,
            np.zeros(n),  # r_now
            coef.ravel(),
        ]
    )
    ctx_addr = ctx.ctypes.data
    y_slot = ctx[1 : 1 + n_y]
    dy_slot = ctx[1 + n_y : 1 + 2 * n_y]
    r_start = 1 + 2 * n_y + 4 + theta.size + 4 * n
    r_now = ctx[r_start : r_start + n]  # written before each call for a Python reference
    fn = lib.pd_rhs

    if spline:

        def rhs(t, y):
            ctx[0] = t
            y_slot[:] = y
            fn(ctx_addr)
            return dy_slot.copy()

    else:

        def rhs(t, y):
            ctx[0] = t
            y_slot[:] = y
            r_now[:] = reference(t)
            fn(ctx_addr)
            return dy_slot.copy()

    rhs.ctx = ctx  # keep the buffer alive with the closure
    return rhs
