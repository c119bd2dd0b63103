"""Streamed IDIM, the parallel filter window by window: `scipy.signal.sosfiltfilt` of a record
that is never held whole.

``sosfiltfilt(sos, x, padlen=P)`` is two passes of ``sosfilt`` over the odd extension
``e = [2x₀ − x_{P..1}, x, 2x_{n−1} − x_{n−2..n−1−P}]``:

1. forward, from the state ``z_i · e₀`` (``z_i = sosfilt_zi(sos)``, the steady state of a unit
   step): ``f = sosfilt(e, zi = z_i · e₀)``;
2. backward, from the state ``z_i · f_{end}``: ``y = reverse(sosfilt(reverse(f), zi = z_i · f_end))``.

``sosfilt`` is a recursion on a state of 2 numbers per section, so the forward pass of a window
``[a, c1)`` continued from the state the previous window left at ``a`` gives the whole record's
forward pass there bit for bit (the same operations in the same order). The first window
(``a = 0``) runs the start padding first and the window that reaches the record's end runs the
end padding after it, exactly as the whole-record call: that window's backward pass is then the
whole record's too. Elsewhere the backward pass starts at the window's end ``c1`` from
``z_i · f_{c1−1}`` instead of the state the record's later samples would give; the difference is a
free response of the filter, which decays over the right margin (`stream_plan.decay_length`).
No left margin is needed at all.

`decimated_window` does this with only the decimated rows computed
(`physid.filters.lifted.decimated_filtfilt`, lifted or not as its caller says, by default as
`lifting_pays` says) and the forward *state* carried, at the window's next decimated row. The
right margin's forward pass is computed again by the next window, unless lifted with a
``carry``: its lifted blocks are then handed to the next window, which starts there.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import signal

from ...filters.lifted import decimated_filtfilt, lifting_pays

__all__ = ["step_state", "decimated_window"]


@functools.lru_cache(maxsize=32)
def _zi(sos_bytes: bytes, n_sections: int) -> np.ndarray:
    sos = np.frombuffer(sos_bytes).reshape(n_sections, 6)
    zi = signal.sosfilt_zi(sos)
    zi.shape = (n_sections, 1, 2)  # sosfiltfilt's layout for time on the last axis of (k, m)
    zi.flags.writeable = False
    return zi


def step_state(sos) -> np.ndarray:
    """``sosfilt_zi(sos)`` shaped (n_sections, 1, 2): times a column of values, the initial
    state `scipy.signal.sosfiltfilt` gives ``sosfilt`` (time on the last axis)."""
    sos = np.ascontiguousarray(sos, dtype=float)
    return _zi(sos.tobytes(), sos.shape[0])


def decimated_window(
    sos, rows, c0, c1, pos, first, count, nd, state, n_full, padlen, lift=None, carry=None
):
    """Rows ``first + j nd`` (j < ``count``) of ``sosfiltfilt(sos, record, padlen=padlen)``
    from a stretch of the record, with `physid.filters.lifted.decimated_filtfilt` (lifted as
    ``lift`` says, by default when `lifting_pays`).

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6)
    rows : ndarray, shape (c1 - c0 or more, k)
        Samples ``c0 ..`` of ``k`` signals, time on axis 0.
    c0, c1 : int
        The record's samples held (``c0 ≤ pos``); the backward pass starts at ``c1 − 1`` (the
        end padding's first when ``c1`` is the record's end ``n_full``, which then needs
        ``c0 ≤ n_full − 1 − padlen``).
    pos : int
        The sample the carried forward state is at (0 with ``state`` None: the record's start,
        through the start padding, which needs ``c0 = 0``).
    first, count, nd : int
        The rows wanted (``pos ≤ first``); with ``count = 0`` only the state is advanced to
        ``first``.
    state : ndarray, shape (n_sections, k, 2) or None
        The forward state before sample ``pos``.
    n_full, padlen : int
        The record's length and the whole-record call's ``padlen``.
    lift : bool, optional
        Lift or not; default `lifting_pays` of the stretch and its columns.
    carry : dict, optional
        `physid.filters.lifted.decimated_filtfilt`'s lifted blocks, from the previous window
        of the same columns (its next row, ``pos == first``) and for the next.

    Returns
    -------
    y : ndarray, shape (k, count)
    state : ndarray, shape (n_sections, k, 2) or None
        The forward state before sample ``first + count · nd`` (None past ``c1``).
    """
    last = c1 == n_full
    x = rows[pos - c0 : c1 - c0]  # time on axis 0, read in place
    if state is None and pos == 0 and padlen > 0:  # the start padding, as sosfiltfilt's
        pad = (2 * x[:1] - x[padlen:0:-1]).T
        zi = step_state(sos)
        _, state = signal.sosfilt(sos, pad, axis=-1, zi=zi * pad[:, :1])
    after = None
    if last and padlen > 0 and count:  # the end padding
        end = rows[n_full - 1 - padlen - c0 : n_full - c0]
        after = 2 * end[-1:] - end[-2::-1]
    if lift is None:
        lift = lifting_pays(nd, x.shape[0] - (first - pos), x.shape[1])
    y, z = decimated_filtfilt(
        sos,
        x,
        nd,
        first - pos,
        count,
        axis=0,
        forward_state=state,
        after=after,
        lift=lift,
        carry=carry,
    )
    if z is not None and first + count * nd > c1:
        z = None
    return y.T, z
