"""The generic C kernel of rigid chains (``models/c/chain_kernel.c``) behind a small Python API.

One C source for every chain (the chain is data), compiled once per machine by
`physid.models.codegen.build_shared_library` and loaded with ctypes: Newton–Euler over N samples,
the mass matrix (Newton–Euler at unit accelerations), the regressor, single-state forward
dynamics and the fused PD closed-loop right-hand side. Without a C compiler `load_kernel`
returns None and `physid.models.rigid` (numpy) does the same work.
"""

from __future__ import annotations

import ctypes
import os
from importlib import resources

import numpy as np

from .rigid import DRIVE_NAMES, RigidChain

__all__ = ["ChainKernel", "load_kernel", "model_buffer", "offset_slots"]

_JS = 36
_MAXJ = 64
_P = ctypes.c_void_p


def _library():
    from .codegen import build_shared_library

    if os.environ.get("PHYSID_NO_C"):
        return None
    source = resources.files("physid.models").joinpath("c/chain_kernel.c").read_text("utf-8")
    lib = build_shared_library(source, "chainkernel")
    if lib is None:
        return None
    lib.rnea_batch.argtypes = [_P, ctypes.c_long, _P, _P, _P, _P, ctypes.c_int, ctypes.c_int]
    lib.rnea_batch.restype = None
    lib.mass_batch.argtypes = [_P, ctypes.c_long, _P, _P]
    lib.mass_batch.restype = None
    lib.regressor_batch.argtypes = [_P, _P, _P, ctypes.c_long, _P, _P, _P, _P]
    lib.regressor_batch.restype = None
    lib.regressor_columns_batch.argtypes = [
        *(_P, _P, _P, _P),
        ctypes.c_long,
        ctypes.c_long,
        *(_P, _P, _P, _P),
        ctypes.c_long,
    ]
    lib.regressor_columns_batch.restype = ctypes.c_int
    lib.forward_one.argtypes = [_P, _P, _P, _P, _P]
    lib.forward_one.restype = ctypes.c_int
    lib.pd_rhs.argtypes = [_P, _P]
    lib.pd_rhs.restype = ctypes.c_int
    return lib


def model_buffer(chain: RigidChain, beta, coulomb_smoothing: float = 0.0) -> np.ndarray:
    """The kernel's model buffer for parameters ``beta`` (see the C source's layout).

    Parameters
    ----------
    chain : RigidChain
    beta : array_like (n_parameters,)
    coulomb_smoothing : float [rad/s]
        0: exact sign(q̇); > 0: tanh(q̇ / v_s) (simulation only).

    Returns
    -------
    ndarray (4 + 36 n,)
    """
    inertia, drive = chain.split(beta)
    n = chain.n_joints
    buf = np.zeros(4 + _JS * n)
    buf[0] = n
    buf[1:4] = chain.gravity
    names = chain.drive_names
    for i in range(n):
        J = buf[4 + i * _JS : 4 + (i + 1) * _JS]
        J[0] = 0.0 if chain.joint_types[i] == "revolute" else 1.0
        J[1:10] = chain.rotation[i].ravel()
        J[10:13] = chain.translation[i]
        J[13:16] = chain.axis[i]
        J[16:26] = inertia[i]
        for c, name in enumerate(names):
            J[26 + DRIVE_NAMES.index(name)] = drive[i, c]
        J[34] = coulomb_smoothing
        J[35] = chain.parents[i]
    return buf


def offset_slots(n_joints: int) -> np.ndarray:
    """Indices of the drive offset ``OF`` of each joint in a model buffer (see `model_buffer`).

    The event-driven exact Coulomb simulation (`physid.simulate.coulomb`) writes the frozen
    Coulomb torque of each joint there, in place, between segments.

    Parameters
    ----------
    n_joints : int

    Returns
    -------
    ndarray of int (n_joints,)
    """
    return 4 + _JS * np.arange(int(n_joints)) + 26 + DRIVE_NAMES.index("OF")


class ChainKernel:
    """Compiled functions of one chain (created by `load_kernel`)."""

    def __init__(self, lib, chain: RigidChain):
        self._lib = lib
        self.chain = chain
        self.n = chain.n_joints
        self._A = np.ascontiguousarray(chain.link_to_joint, dtype=float)
        self._mask = np.array([1.0 if d in chain.drive else 0.0 for d in DRIVE_NAMES])

    def rnea(self, beta, Q, QD, QDD, *, gravity=True, drive=True) -> np.ndarray:
        """τ (N, n) at the states given as C-contiguous float64 arrays (N, n)."""
        buf = model_buffer(self.chain, beta)
        Q, QD, QDD = (np.ascontiguousarray(x, dtype=float) for x in (Q, QD, QDD))
        out = np.empty_like(Q)
        self._lib.rnea_batch(
            buf.ctypes.data,
            Q.shape[0],
            Q.ctypes.data,
            QD.ctypes.data,
            QDD.ctypes.data,
            out.ctypes.data,
            int(gravity),
            int(drive),
        )
        return out

    def mass(self, beta, Q) -> np.ndarray:
        """M(q) (N, n, n)."""
        buf = model_buffer(self.chain, beta)
        Q = np.ascontiguousarray(Q, dtype=float)
        out = np.empty((Q.shape[0], self.n, self.n))
        self._lib.mass_batch(buf.ctypes.data, Q.shape[0], Q.ctypes.data, out.ctypes.data)
        return out

    def regressor(self, Q, QD, QDD, out=None) -> np.ndarray:
        """Y (N, n, n_parameters); written into ``out`` when given."""
        buf = model_buffer(self.chain, self.chain.nominal_vector())
        Q, QD, QDD = (np.ascontiguousarray(x, dtype=float) for x in (Q, QD, QDD))
        N = Q.shape[0]
        shape = (N, self.n, self.n * self.chain.per_joint)
        if out is None:
            out = np.empty(shape)
        self._lib.regressor_batch(
            buf.ctypes.data,
            self._A.ctypes.data,
            self._mask.ctypes.data,
            N,
            Q.ctypes.data,
            QD.ctypes.data,
            QDD.ctypes.data,
            out.ctypes.data,
        )
        return out

    def regressor_columns(self, Q, QD, QDD, columns, out) -> np.ndarray:
        """The regressor's ``columns`` written into ``out`` (N, n, len(columns)), a view whose
        rows may be spaced wider (a wider array's leading columns): the gather done in C, a
        sample at a time, without Y (N, n, n_parameters) in memory.

        Parameters
        ----------
        Q, QD, QDD : ndarray, shape (N, n) [rad, rad/s, rad/s²]
        columns : sequence of int
            Columns of the drive-and-link regressor (those of `regressor`).
        out : ndarray, shape (N, n, len(columns)), float64
            Its last two axes contiguous (strides 8·len(columns) and 8 bytes); its rows at any
            stride (a multiple of 8 bytes).

        Returns
        -------
        ndarray
            ``out``.
        """
        buf = model_buffer(self.chain, self.chain.nominal_vector())
        Q, QD, QDD = (np.ascontiguousarray(x, dtype=float) for x in (Q, QD, QDD))
        cols = np.ascontiguousarray(columns, dtype=np.int64)
        k = cols.size
        if (
            out.dtype != np.float64
            or out.shape != (Q.shape[0], self.n, k)
            or out.strides[1:] != (8 * k, 8)
            or out.strides[0] % 8
            or (cols.size and (cols.min() < 0 or cols.max() >= self.n * self.chain.per_joint))
        ):
            raise ValueError("regressor_columns: out or columns do not fit the chain")
        status = self._lib.regressor_columns_batch(
            buf.ctypes.data,
            self._A.ctypes.data,
            self._mask.ctypes.data,
            cols.ctypes.data,
            k,
            Q.shape[0],
            Q.ctypes.data,
            QD.ctypes.data,
            QDD.ctypes.data,
            out.ctypes.data,
            out.strides[0] // 8,
        )
        if status != 0:
            raise MemoryError("regressor_columns: no memory for one sample's regressor")
        return out

    def mass_and_bias(self, beta, coulomb_smoothing: float = 0.0):
        """``f(q, qd) -> (M, h)`` of one state (rigid bodies and joint drive terms), bound.

        For models whose remaining terms (motor-side, through a coupling) are added in Python.
        """
        buf = model_buffer(self.chain, beta, coulomb_smoothing)
        n = self.n
        work = np.zeros(3 * n)
        q_s, qd_s, z_s = work[:n], work[n : 2 * n], work[2 * n :]
        M = np.zeros((n, n))
        h_s = np.zeros(n)
        lib, baddr = self._lib, buf.ctypes.data

        def f(q, qd):
            q_s[:] = q
            qd_s[:] = qd
            lib.mass_batch(baddr, 1, q_s.ctypes.data, M.ctypes.data)
            lib.rnea_batch(
                baddr, 1, q_s.ctypes.data, qd_s.ctypes.data, z_s.ctypes.data, h_s.ctypes.data, 1, 1
            )
            return M.copy(), h_s.copy()

        f.buffers = (buf, work, M, h_s)
        return f

    def forward_one(self, beta, coulomb_smoothing: float = 0.0):
        """``f(q, qd, tau) -> qdd`` for one state, parameters bound."""
        buf = model_buffer(self.chain, beta, coulomb_smoothing)
        n = self.n
        work = np.zeros(4 * n)
        q_s, qd_s, tau_s, out = work[:n], work[n : 2 * n], work[2 * n : 3 * n], work[3 * n :]
        addr = work.ctypes.data
        step = 8 * n
        fn = self._lib.forward_one
        baddr = buf.ctypes.data

        def f(q, qd, tau):
            q_s[:] = q
            qd_s[:] = qd
            tau_s[:] = tau
            if fn(baddr, addr, addr + step, addr + 2 * step, addr + 3 * step) != 0:
                from ..errors import SimulationError

                raise SimulationError(
                    "the mass matrix is not positive definite at this state: check the "
                    "parameters (masses and inertias must be physical)."
                )
            return out.copy()

        f.buffers = (buf, work)
        return f

    def pd_rhs(self, beta, kp, kd, reference, spline=None, coulomb_smoothing: float = 0.0):
        """The PD closed loop ``f(t, y) -> ẏ`` as one C call.

        ``spline``: ``(t0, step, coefficients (n_int, n, 4), first, last)`` of a cubic spline
        reference with uniform knots, evaluated in C; else ``reference(t)`` is called in Python.
        """
        from ..errors import SimulationError

        n = self.n
        buf = model_buffer(self.chain, beta, coulomb_smoothing)
        if spline is not None:
            t0, step, coef, first, last = spline
            coef = np.asarray(coef, dtype=float)
            n_int = coef.shape[0]
            first, last = np.asarray(first, dtype=float), np.asarray(last, dtype=float)
        else:
            t0, step, n_int = 0.0, 1.0, 0
            coef = np.zeros(0)
            first = last = np.zeros(n)
        ny = 2 * n
        ctx = np.concatenate(
            [
                np.zeros(1 + 2 * ny),
                [t0, step, float(n_int), 1.0 if spline is not None else 0.0],
                np.asarray(kp, dtype=float),
                np.asarray(kd, dtype=float),
                first,
                last,
                np.zeros(n),
                coef.ravel(),
            ]
        )
        addr = ctx.ctypes.data
        baddr = buf.ctypes.data
        y_slot = ctx[1 : 1 + ny]
        dy_slot = ctx[1 + ny : 1 + 2 * ny]
        r_start = 1 + 2 * ny + 4 + 4 * n
        r_now = ctx[r_start : r_start + n]
        fn = self._lib.pd_rhs

        def fail(t):
            raise SimulationError(
                f"the mass matrix is not positive definite at t = {t:.6g} s: the state left the "
                "physical range; check the parameters and the gains."
            )

        if spline is not None:

            def rhs(t, y):
                ctx[0] = t
                y_slot[:] = y
                if fn(addr, baddr):
                    fail(t)
                return dy_slot.copy()

        else:

            def rhs(t, y):
                ctx[0] = t
                y_slot[:] = y
                r_now[:] = reference(t)
                if fn(addr, baddr):
                    fail(t)
                return dy_slot.copy()

        rhs.buffers = (ctx, buf)
        return rhs


_STATE = {"lib": None, "tried": False}


def load_kernel(chain: RigidChain) -> ChainKernel | None:
    """The compiled kernel for ``chain``, or None (no compiler, build failed, > 64 joints).

    Parameters
    ----------
    chain : RigidChain

    Returns
    -------
    ChainKernel or None
    """
    if chain.n_joints > _MAXJ:
        return None
    if not _STATE["tried"]:
        _STATE["lib"] = _library()  # an error (a relative PHYSID_CACHE_DIR) is raised each time
        _STATE["tried"] = True
    lib = _STATE["lib"]
    return None if lib is None else ChainKernel(lib, chain)
