"""A zero-phase IIR filter evaluated only at every ``nd``-th sample (the lifted forward-backward
filter).

``scipy.signal.sosfiltfilt`` followed by keeping one sample in ``nd`` runs two ``sosfilt`` passes
over every sample and throws ``nd − 1`` of every ``nd`` outputs away. The filter is linear, so
over a block of ``nd`` samples its state and its output at the block's first sample are linear in
the block's samples and the states at the block's two ends ("lifting"). Only one matrix product
touches every sample; two short recursions run at the block rate. The result equals
``sosfiltfilt(sos, x, padlen=P)[..., first::nd]`` up to rounding: relative ~1e-14 at small
nd, growing to ~1e-11 at nd = 1000 for the IDIM parallel filter, as ``sosfilt``'s own rounding
does on states that span many decades.

The state-space form is the cascade of the sections' transposed direct form II, exactly the
states ``sosfilt`` carries (``zi``/``zf``, shape (n_sections, k, 2)): section ``s`` with
``b0 b1 b2 1 a1 a2`` has ``y = z₀ + b₀ u``, ``z₀' = −a₁ z₀ + z₁ + (b₁ − a₁ b₀) u``,
``z₁' = −a₂ z₀ + (b₂ − a₂ b₀) u``, and its ``y`` is the next section's ``u``. Forward:
``X[i+1] = A X[i] + B u[i]``, ``f[i] = C X[i] + D u[i]``. Backward, with ``S[i]`` the state
before the reversed pass processes sample ``i``: ``S[i−1] = A S[i] + B f[i]``,
``y[i] = C S[i] + D f[i]``. For the block of samples ``m .. m + nd − 1`` (``R`` the backward state
after the block's first sample, ``S[m − 1]``, and ``u`` the block's samples):

* ``X[m + nd] = Aⁿᵈ X[m] + G u``, ``G[:, l] = A^(nd−1−l) B``;
* ``f_blk = F X[m] + T u``, ``F[k] = C Aᵏ``, ``T[k, l] = h[k − l]`` (``h`` the impulse response);
* ``R_j = Aⁿᵈ R_{j+1} + K f_blk``, ``K[:, k] = Aᵏ B``, so ``R_j = Aⁿᵈ R_{j+1} + P X[m] + Q u`` with
  ``P = K F`` and ``Q = K T``;
* ``y[m] = C A^(nd−1) R_{j+1} + h·f_blk = Ψ R_{j+1} + (h F) X[m] + r u``, ``r = h T``.

The samples before the first kept row and after the last block (the padding) run through
``sosfilt`` as in ``sosfiltfilt``.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = [
    "LIFT_MIN_ND",
    "LIFT_MIN_WORK",
    "lifting_pays",
    "decimated_filtfilt",
    "sosfiltfilt_decimated",
]

#: Smallest decimation factor at which the lifted filter can be faster than two ``sosfilt``
#: passes, and the smallest ``nd × columns``: the two block-rate recursions cost ~5 µs a block
#: whatever the number of columns, the per-sample product ~(4 n_sections + 1)·2/nd flops. Measured
#: (one thread, the 8th-order filter of the IDIM decimation, 2e5 samples, time on axis 0), lifted
#: / sosfiltfilt time: 190 columns 1.33 (nd 4), 0.90 (6), 0.68 (8), 0.47 (12), 0.38 (16);
#: 16 columns 3.5 (6), 2.1 (10), 1.23 (16).
LIFT_MIN_ND = 6
#: See `LIFT_MIN_ND`.
LIFT_MIN_WORK = 400


def lifting_pays(nd: int, n_samples: int, n_columns: int) -> bool:
    """Whether `decimated_filtfilt` lifts (True) or runs ``sosfilt`` on every sample (False).

    Parameters
    ----------
    nd : int
        Decimation factor [samples].
    n_samples : int
        Samples of the stretch filtered.
    n_columns : int
        Signals filtered together.

    Returns
    -------
    bool
        ``nd ≥ LIFT_MIN_ND``, ``nd · n_columns ≥ LIFT_MIN_WORK`` and the stretch holds at least
        two blocks.
    """
    nd = int(nd)
    return nd >= LIFT_MIN_ND and nd * int(n_columns) >= LIFT_MIN_WORK and n_samples >= 2 * nd


def _state_space(sos: np.ndarray):
    """``(A, B, C, D)`` of the cascade of ``sos``'s sections in ``sosfilt``'s state order."""
    ns = sos.shape[0]
    n = 2 * ns
    A, B, C = np.zeros((n, n)), np.zeros(n), np.zeros(n)
    D = 1.0
    for s, (b0, b1, b2, _a0, a1, a2) in enumerate(sos / sos[:, 3:4]):
        i = 2 * s
        # the section's input is the cascade so far: u_s = C_prev X + D_prev u
        A[i : i + 2, :i] = np.outer([b1 - a1 * b0, b2 - a2 * b0], C[:i])
        A[i : i + 2, i : i + 2] = [[-a1, 1.0], [-a2, 0.0]]
        B[i : i + 2] = np.array([b1 - a1 * b0, b2 - a2 * b0]) * D
        C[:i] *= b0  # y_s = z0_s + b0 u_s
        C[i] = 1.0
        D *= b0
    return A, B, C, D


@functools.lru_cache(maxsize=16)
def _matrices(sos_bytes: bytes, n_sections: int, nd: int):
    """The lifted filter of ``sos`` for blocks of ``nd`` samples (see the module docstring).

    Returns ``(MT, Phi, P, Psi, hF, A, B, C, D)``: ``MT`` (2 n_s + 2 n_s + 1, nd) the rows
    ``[G; Q; r]`` that multiply every block of samples; the rest small.
    """
    sos = np.frombuffer(sos_bytes).reshape(n_sections, 6)
    A, B, C, D = _state_space(sos)
    n = A.shape[0]
    pw = np.empty((nd + 1, n, n))  # A^k, k = 0 .. nd
    pw[0] = np.eye(n)
    for k in range(nd):
        pw[k + 1] = A @ pw[k]
    K = pw[:nd] @ B  # (nd, n): row k = A^k B
    F = pw[:nd].transpose(0, 2, 1) @ C  # (nd, n): row k = C A^k
    h = np.empty(nd)  # impulse response h[0] = D, h[k] = C A^(k-1) B
    h[0] = D
    h[1:] = K[: nd - 1] @ C
    G = K[::-1].T  # (n, nd): column l = A^(nd-1-l) B
    # Q[:, l] = sum_k K[k] h[k-l] = A^l sum_{i < nd-l} A^i B h[i] = A^l v[nd-l]
    v = np.concatenate([np.zeros((1, n)), np.cumsum(K * h[:, None], axis=0)])
    Q = np.einsum("lij,lj->il", pw[:nd], v[nd - np.arange(nd)])
    r = np.correlate(h, h, "full")[nd - 1 :]  # r[l] = sum_k h[k] h[k-l]
    P = K.T @ F  # sum_k A^k B C A^k
    hF = h @ F
    MT = np.ascontiguousarray(np.concatenate([G, Q, r[None, :]], axis=0))
    out = (MT, pw[nd], P, C @ pw[nd - 1], hF, A, B, C, D)
    for a in out:
        if isinstance(a, np.ndarray):
            a.flags.writeable = False
    return out


def _flat(state: np.ndarray) -> np.ndarray:
    """sosfilt's (n_sections, k, 2) state as (2 n_sections, k) (state index 2 s + j)."""
    return state.transpose(0, 2, 1).reshape(2 * state.shape[0], state.shape[1])


def _sos_state(flat: np.ndarray) -> np.ndarray:
    """(2 n_sections, k) as sosfilt's (n_sections, k, 2)."""
    return np.ascontiguousarray(
        flat.reshape(flat.shape[0] // 2, 2, flat.shape[1]).transpose(0, 2, 1)
    )


def _recursion(g: np.ndarray, Phi: np.ndarray, x0: np.ndarray, out=None) -> np.ndarray:
    """``X[0] = x0``, ``X[j+1] = Phi X[j] + g[j]`` for ``g`` of shape (L, n, k): (L + 1, n, k)
    (written into ``out`` when given).

    A true recursion at the block rate (``L = n_samples / nd`` steps, each one (n, n) by (n, k)
    product). Grouping it into blocks of steps with powers of ``Phi`` lost up to 1e-8 relative
    (the states span ~18 decades and the powers of the non-normal ``Phi`` cancel).
    """
    L, n, k = g.shape
    out = np.empty((L + 1, n, k)) if out is None else out
    out[0] = x0
    for j in range(L):
        np.matmul(Phi, out[j], out=out[j + 1])
        out[j + 1] += g[j]
    return out


def _check(sos, x, nd, first, count, axis):
    from ..errors import InputError

    sos = np.ascontiguousarray(sos, dtype=float)
    if sos.ndim != 2 or sos.shape[1] != 6 or sos.shape[0] == 0:
        raise InputError(f"sos must have shape (n_sections, 6); got {sos.shape}.")
    if axis not in (0, -1, 1):
        raise InputError(f"axis must be 0 or -1 (the time axis of a 2-D x); got {axis!r}.")
    x = np.asarray(x, dtype=float)
    if x.ndim != 2:
        raise InputError(f"x must be 2-D, (k, n_samples) or (n_samples, k); got {x.shape}.")
    xt = x if axis == 0 else x.T  # (n_samples, k), a view
    if int(nd) < 1:
        raise InputError(f"nd must be a positive integer; got {nd}.")
    if int(first) < 0 or int(count) < 0:
        raise InputError(f"first and count must be >= 0; got first={first}, count={count}.")
    if count and int(first) + (int(count) - 1) * int(nd) >= xt.shape[0]:
        raise InputError(
            f"the last row asked for, first + (count - 1)·nd = "
            f"{int(first) + (int(count) - 1) * int(nd)}, lies past x's {xt.shape[0]} samples."
        )
    return sos, xt


def _carried(carry, sos, nd: int, k: int) -> dict:
    """The lifted blocks ``carry`` holds for this call (``{}`` when none), after checking that
    they were made with the same ``sos``, ``nd`` and number of signals; ``carry`` is emptied for
    this call's."""
    from ..errors import InputError

    if carry is None:
        return {}
    if not isinstance(carry, dict):
        raise InputError(f"carry must be a dict (empty at first); got {type(carry).__name__}.")
    known = dict(carry)
    carry.clear()
    if "Z" not in known:
        return {}
    made = known.get("key")
    if made is None or made[0] != nd or made[1] != sos.tobytes() or made[2] != k:
        got = "unknown" if made is None else f"nd={made[0]}, {made[2]} signals"
        raise InputError(
            f"carry holds blocks of another filter (made with {got}; this call: nd={nd}, "
            f"{k} signals, or another sos): pass the carry of a call with the same sos, nd "
            "and signals, or an empty dict."
        )
    return known


def decimated_filtfilt(
    sos,
    x,
    nd: int,
    first: int,
    count: int,
    *,
    axis=-1,
    forward_state=None,
    after=None,
    lift=None,
    carry=None,
):
    """Forward-backward ``sosfilt`` of a stretch, only at samples ``first + j nd``.

    The forward pass starts from ``forward_state`` at the stretch's first sample and runs on
    through ``after``; the backward pass starts at the last sample of ``after`` (of ``x`` when
    None) from the step state ``sosfilt_zi(sos) · f[-1]``, as `scipy.signal.sosfiltfilt` does
    at the end of its padded signal.

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6)
        The filter, in second-order sections (`scipy.signal` layout).
    x : ndarray, shape (k, n_samples) or (n_samples, k)
        ``k`` signals (any units; the output has the same), time on ``axis``.
    nd : int
        Spacing of the rows wanted [samples].
    first : int
        The first row wanted (a sample index of ``x``).
    count : int
        Rows wanted: ``first, first + nd, …, first + (count − 1) nd`` (all inside ``x``).
    axis : {-1, 0}
        The time axis of ``x``, ``after`` and the output. Both are fast: the samples are read in
        place, as blocks of ``nd`` (time on axis 0 is the faster of the two).
    forward_state : ndarray, shape (n_sections, k, 2), optional
        The forward pass's state before the stretch's first sample (``sosfilt``'s ``zi``);
        default ``sosfilt_zi(sos) · x[0]``.
    after : ndarray, optional
        Samples that follow ``x`` (the end padding), time on ``axis``; no row is taken there.
    lift : bool, optional
        Lift (True) or run ``sosfilt`` on every sample (False); default `lifting_pays`.
    carry : dict, optional
        The lifted blocks a previous call computed beyond its last row wanted, reused here and
        replaced by this call's: on entry, ``carry["Z"]`` and ``carry["X"]`` (when present)
        are the block products (with their forward-state terms) and forward states of this
        call's first blocks, from ``first`` on, of the same signals (the caller checks that
        they are: the stretches overlap, the previous call's ``first + count·nd`` is this
        call's ``first``); on return, those of the blocks from ``first + count · nd`` on (empty
        when none were lifted), with ``carry["key"]``: the ``nd``, ``sos`` and number of
        signals they were made with, checked on entry (another raises `InputError`). The
        forward pass is a recursion continued from the same state over the same samples, so
        these blocks are bit for bit what this call would compute (``forward_state`` is then
        not used for them).

    Returns
    -------
    y : ndarray, shape (k, count) or (count, k)
        The filtered rows, time on ``axis``.
    state : ndarray, shape (n_sections, k, 2) or None
        The forward pass's state before sample ``first + count · nd`` of ``x`` (to continue the
        forward pass on the samples that follow), or None when that lies past ``x``'s end.

    Notes
    -----
    Lifted, the cost per sample and column is one product with a (4 n_sections + 1, nd) matrix
    (BLAS), plus two recursions over the ``n_samples / nd`` blocks (a Python loop of small
    products). Peak memory beyond ``x``: ``k · n_samples · (6 n_sections + 1) / nd`` floats (the
    product, then the block states of one pass; 25/nd of ``x`` for 4 sections) and copies of the
    samples before ``first`` and after the last whole block (for ``sosfilt``). The matrices of
    ``(sos, nd)`` are cached (16 pairs). One function of ~75 lines of code: the head, the lifted
    blocks, the tail and the backward recursion hand their states to one another.
    """
    from scipy import signal

    sos, xt = _check(sos, x, nd, first, count, axis)
    nd, first, count = int(nd), int(first), int(count)
    n, k = xt.shape
    ns = sos.shape[0]
    zi = signal.sosfilt_zi(sos)[:, None, :]
    z = zi * xt[0][:, None] if forward_state is None else np.asarray(forward_state, dtype=float)
    if z.shape != (ns, k, 2):
        raise ValueError(f"forward_state must have shape {(ns, k, 2)}; got {z.shape}")
    if first > 0:  # the head: the samples before the first row wanted
        _, z = signal.sosfilt(sos, xt[:first].T, axis=-1, zi=z)
    end = first + count * nd  # the forward state wanted before this sample
    known = _carried(carry, sos, nd, k)
    if count == 0:
        y0 = np.empty((k, 0))
        return (y0 if axis != 0 else y0.T), z if end <= n else None
    if lift is None:
        lift = lifting_pays(nd, n - first, k)
    # whole blocks, leaving at least one sample after them (the backward pass starts there),
    # past the last row wanted too: the backward pass's run-in is lifted as well
    L = (n - 1 - first) // nd if lift and nd > 1 else 0
    J = min(count, L)  # rows from the lifted blocks; the others from the tail
    y = np.empty((k, count))
    zend = None
    if L:
        MT, Phi, P, Psi, hF = _matrices(sos.tobytes(), ns, nd)[:5]
        nx = 2 * ns
        blocks = xt[first : first + L * nd].reshape(L, nd, k)
        Z, X = np.empty((L, 2 * nx + 1, k)), np.empty((L + 1, nx, k))
        have = min(known["Z"].shape[0], L) if "Z" in known else 0  # blocks known already
        if have:
            Z[:have], X[: have + 1] = known["Z"][:have], known["X"][: have + 1]
        else:
            X[0] = _flat(z)
        np.matmul(MT, blocks[have:], out=Z[have:])  # (L, 2 nx + 1, k): G u, Q u, r u per block
        _recursion(Z[have:, :nx], Phi, X[have], out=X[have:])  # X[m + nd] = A^nd X[m] + G u
        z = _sos_state(X[L])
        if count <= L:
            zend = _sos_state(X[count])
        for i in range(have, L, 1024):  # in place, a slice at a time (bounded temporaries)
            sl = slice(i, min(i + 1024, L))
            Z[sl, nx : 2 * nx] += np.matmul(P, X[sl])  # W_j = P X_j + Q u_j
            Z[sl, 2 * nx] += np.matmul(hF, X[sl])  # the part of y_j known going forward
        if carry is not None and count < L:  # the blocks past the last row wanted
            carry["Z"], carry["X"] = Z[count:].copy(), X[count:].copy()
            carry["key"] = (nd, sos.tobytes(), k)
        del X
    # the tail: sosfilt forward from the last block's end, then backward from the end
    t0 = first + L * nd
    tail = xt[t0:].T
    if after is not None:
        tail = np.concatenate([tail, np.asarray(after, dtype=float).T if axis == 0 else after], 1)
    if t0 < end <= n:  # split the forward pass where its state is wanted
        f1, zend = signal.sosfilt(sos, tail[:, : end - t0], axis=-1, zi=z)
        if tail.shape[1] > end - t0:
            f2, _ = signal.sosfilt(sos, tail[:, end - t0 :], axis=-1, zi=zend)
            f = np.concatenate([f1, f2], axis=1)
        else:  # the wanted state is at the record's very end
            f = f1
    else:
        f, _ = signal.sosfilt(sos, tail, axis=-1, zi=z)
    back, zb = signal.sosfilt(sos, f[:, ::-1], axis=-1, zi=zi * f[:, -1:])
    rows = np.arange(J, count) * nd + first - t0
    y[:, J:] = back[:, f.shape[1] - 1 - rows]
    if L:
        # R_j = A^nd R_{j+1} + P X_j + Q u_j (R_j: the backward state after block j's first
        # sample); R_L from the tail's backward pass
        R = _recursion(Z[::-1, nx : 2 * nx], Phi, _flat(zb))[::-1]
        # y_j = Ψ R_{j+1} + hF X_j + r u_j
        y[:, :J] = (Psi @ R[1 : J + 1] + Z[:J, 2 * nx]).T
    return (y.T if axis == 0 else y), zend


def sosfiltfilt_decimated(
    sos, x, nd: int, first: int = 0, count=None, *, axis=-1, padlen=None, lift=None
):
    """``scipy.signal.sosfiltfilt(sos, x, axis=axis, padlen=padlen)`` at samples ``first + j nd``
    (``j < count``), computed only there.

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6)
        The filter, in second-order sections.
    x : array_like, shape (k, n_samples) or (n_samples, k)
        ``k`` signals, time on ``axis``.
    nd : int
        Spacing of the rows kept [samples].
    first : int
        The first row kept.
    count : int, optional
        Rows kept (default: all to the end).
    axis : {-1, 0}
        The time axis of ``x`` and of the output.
    padlen : int, optional
        Odd-extension length at each end, as `scipy.signal.sosfiltfilt` (default scipy's,
        ``3 (2 n_sections + 1 − min(#b2 == 0, #a2 == 0))``); must be below ``n_samples``.
    lift : bool, optional
        See `decimated_filtfilt`.

    Returns
    -------
    ndarray, shape (k, count) or (count, k)

    Notes
    -----
    Memory: `decimated_filtfilt`'s (``x`` is not copied; the padding is ``padlen`` samples).
    """
    from scipy import signal

    from ..errors import InputError

    sos, xt = _check(sos, x, nd, first, 0, axis)
    n, k = xt.shape
    if padlen is None:
        ntaps = 2 * sos.shape[0] + 1
        ntaps -= min((sos[:, 2] == 0).sum(), (sos[:, 5] == 0).sum())
        padlen = 3 * ntaps
    padlen = int(padlen)
    if not 0 <= padlen < n:
        raise InputError(f"padlen must be in [0, n_samples) = [0, {n}); got {padlen}.")
    if count is None:
        count = max(0, -(-(n - int(first)) // int(nd)))
    if count and int(first) + (int(count) - 1) * int(nd) >= n:
        raise InputError(
            f"rows past the record's {n} samples asked for (first={first}, count={count}, nd={nd})."
        )
    zi = signal.sosfilt_zi(sos)[:, None, :]
    z, after = zi * xt[0][:, None], None
    if padlen:  # sosfiltfilt's odd extension: the start's forward pass, the end's samples
        pad = (2 * xt[:1] - xt[padlen:0:-1]).T
        _, z = signal.sosfilt(sos, pad, axis=-1, zi=zi * pad[:, :1])
        after = 2 * xt[-1:] - xt[-2 : -padlen - 2 : -1]
        after = after if axis == 0 else after.T
    y, _ = decimated_filtfilt(
        sos, x, nd, int(first), count, axis=axis, forward_state=z, after=after, lift=lift
    )
    return y
