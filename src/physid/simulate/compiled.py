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
import sys

import numpy as np

__all__ = ["compiled_pd_rhs", "compiler", "c_source"]

#: Bump when the generated C changes, so cached libraries are rebuilt.
_GENERATOR_VERSION = "pdrhs-2"
_LIBS: dict[str, ctypes.CDLL] = {}


def compiler() -> str | None:
    """Path of the C compiler used ($CC, else cc, gcc or clang on PATH), or None."""
    from ..models.codegen import compiler as _compiler

    return _compiler()


def c_source(model) -> str:
    """C source of the model's closed-loop ``pd_rhs`` (`physid.models.codegen.c_pd_rhs_source`).

    Parameters
    ----------
    model : ChainModel
        A symbolic (point-mass) chain.

    Returns
    -------
    str
    """
    from ..models.codegen import c_pd_rhs_source

    return c_pd_rhs_source(model.symbolic_equations())


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
    from ..models.codegen import build_shared_library

    key = _library_key(model)
    if key in _LIBS:
        return _LIBS[key]
    lib = build_shared_library(lambda: c_source(model), "pdrhs", key=key, cc=compiler())
    if lib is None:
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
