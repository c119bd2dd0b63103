"""What the linear-ODE estimators' block fits share: reading the model's two channels from a block
source, the whole-record checks from running statistics, thinned histories, and the verdict's
open-loop prediction (training fit, sign-flip and partial-fit checks) simulated block by block.

Every function here holds a block and a few numbers per quantity, never the record: memory is
constant in the record's length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._validate import check_int
from ..errors import EstimationError, InputError, arg
from ._linear import check_distinct_channels, check_known_finite, refuse_same_signal
from .plausibility import check_magnitude, flipped_segments, partial_segments, unchanging

#: Segments of the record whose correlations the gate compares (as `linear_ode_problems`).
SEGMENTS = 8


def open_source(source, model, known, block_samples, keep):
    """``(source, in_name, out_name, size, keep)`` checked: the block source of ``source``, the
    model's input and output channels in it, and the block and history sizes."""
    from ..signals.blocks import as_block_source

    src = as_block_source(source)
    size = check_int(
        block_samples,
        "block_samples",
        minimum=2,
        fix="Read at least 2 samples at a time (65536 by default).",
    )
    keep = check_int(keep, "keep", minimum=2, fix="Keep at least 2 samples of each history.")
    units = dict(zip(src.names, src.units, strict=False))
    in_name, out_name = model.recording_channels(src.names, units)
    check_distinct_channels(in_name, out_name)
    check_known_finite(known)
    if src.n_samples < 2:
        raise EstimationError(f"the record has {src.n_samples} sample(s); a fit needs more.")
    return src, in_name, out_name, size, keep


def pairs(src, in_name: str, out_name: str, size: int, bar=None):
    """``(start, block, u, y)`` for each block of ``src`` (the model's input and output)."""
    start = 0
    for block in src.blocks(size, channels=[in_name, out_name]):
        u = np.asarray(block[in_name], dtype=float)
        y = np.asarray(block[out_name], dtype=float)
        yield start, block, u, y
        start += u.size
        if bar is not None:
            bar.advance(u.size)
    if start != src.n_samples:
        raise EstimationError(
            f"the block source handed out {start} samples but declares {src.n_samples}; the file "
            "changed while it was read, or its reader is broken."
        )


def progress_bar(enabled: bool, total: int, label: str):
    """A `physid._progress.Progress` over ``total`` samples read (every pass counted: a fit that
    stops early, e.g. without a trustworthy estimate to simulate, ends below it), or a silent
    stand-in. The line (``label: 12000/36000 samples read, 3 s, about 6 s left``) shows after 2 s
    on a terminal only: never with ``--quiet`` or ``--json`` to a pipe."""
    from .. import _progress

    if not enabled:
        return _Silent()
    return _progress.Progress(total, label, unit="samples read")


class _Silent:
    def advance(self, n: int = 1) -> None:
        """Nothing."""

    def close(self) -> None:
        """Nothing."""


@dataclass
class RecordStats:
    """Running statistics of the two channels for the in-memory fit's whole-record checks.

    ``check_magnitude`` runs on every block (the same limit); the input-equals-output test
    (`check_distinct_signals`) uses sums about the first sample (no cancellation of a large
    mean); the unchanging-output test uses the output's extremes (both of ``y − offset``).
    """

    names: tuple[str, str]
    offset: float = 0.0  # subtracted from y for the extremes and sums (a held output offset)
    n: int = 0
    shift: tuple[float, float] | None = None
    sums: np.ndarray = field(default_factory=lambda: np.zeros(5))  # Σu Σy Σuu Σyy Σuy (shifted)
    u_max: float = 0.0
    y_min: float = math.inf
    y_max: float = -math.inf

    def add(self, u: np.ndarray, y: np.ndarray) -> None:
        """Take one block (the magnitude check raises on it)."""
        check_magnitude((u, y), self.names)
        y = y - self.offset
        if self.shift is None:
            self.shift = (float(u[0]), float(y[0]))
        a, b = u - self.shift[0], y - self.shift[1]
        self.sums += [a.sum(), b.sum(), a @ a, b @ b, a @ b]
        self.n += u.size
        self.u_max = max(self.u_max, float(np.abs(u).max(initial=0.0)))
        self.y_min = min(self.y_min, float(y.min()))
        self.y_max = max(self.y_max, float(y.max()))

    def check_distinct(self) -> None:
        """`check_distinct_signals` on the whole record, from the sums."""
        su, sy, suu, syy, suy = self.sums
        n = self.n
        uu, yy, uy = suu - su * su / n, syy - sy * sy / n, suy - su * sy / n
        nu, ny = math.sqrt(max(uu, 0.0)), math.sqrt(max(yy, 0.0))
        refuse_same_signal(nu, ny, uy, n, self.u_max)

    def unchanging(self, out_name: str) -> str | None:
        """`unchanging` of the output, from its extremes."""
        return unchanging(np.array([[self.y_min], [self.y_max]]), [out_name])


class Thinned:
    """Every ``step``-th sample of a history (``step = ceil(n / keep)``), collected per block."""

    def __init__(self, n_samples: int, keep: int):
        self.step = max(1, math.ceil(n_samples / keep))
        self.parts: dict[str, list] = {}

    def pick(self, start: int, n_new: int) -> np.ndarray:
        """Local indices of the kept samples of a block starting at sample ``start``."""
        first = (-start) % self.step
        return np.arange(first, n_new, self.step)

    def add(self, **arrays) -> None:
        """Append the kept rows of named arrays."""
        for name, value in arrays.items():
            self.parts.setdefault(name, []).append(value)

    def get(self, name: str, empty) -> np.ndarray:
        """The concatenated history ``name`` (``empty`` when nothing was kept)."""
        parts = self.parts.get(name)
        return np.concatenate(parts) if parts else empty

    def note(self, n_samples: int) -> str | None:
        """The sentence for the result's notes when the histories were thinned."""
        if self.step == 1:
            return None
        return (
            f"the per-sample histories hold one sample in {self.step} of the {n_samples} "
            "(keep); the final estimate uses them all"
        )


class UniformTimes:
    """``t0 + k·dt`` indexed like an array (the sentences of the segment checks quote times)."""

    def __init__(self, t0: float, dt: float):
        self.t0, self.dt = float(t0), float(dt)

    def __getitem__(self, k) -> float:
        return self.t0 + self.dt * int(k)


class _Chain:
    """One open-loop simulation of a linear ODE continued block by block: each block starts at
    the previous block's last sample, from the output derivatives simulated there (exact: the
    discretisation is the same matrix exponential, the state is carried)."""

    def __init__(self, model, params, x0=None):
        self.model, self.params, self.x0 = model, params, x0
        self.last = None  # (t, u, derivatives) of the last sample

    def run(self, t, u):
        """The simulated output at the block's samples (NaN when it cannot be simulated)."""
        from ..simulate.linear import simulate_linear_ode

        n = self.model.order
        overlap = self.last is not None
        x0 = self.x0
        if overlap:
            t0, u0, x0 = self.last
            t = np.concatenate([[t0], t])
            u = None if u is None else np.concatenate([[u0], u])
        try:
            with np.errstate(all="ignore"):
                rec = simulate_linear_ode(
                    self.model, t, input=u, x0=x0, params=self.params, output_derivatives=True
                )
            cols = ["x"] + [f"x_d{k}" for k in range(1, n)]
            d = np.column_stack([np.asarray(rec[c], dtype=float) for c in cols])
        except Exception:  # an unstable or degenerate identified model: no prediction
            d = np.full((t.size, n), np.nan)
        self.last = (t[-1], None if u is None else u[-1], d[-1])
        return d[1:, 0] if overlap else d[:, 0]


class PredictionStats:
    """The open-loop prediction of the whole record (`simulate_prediction`) reduced to the
    per-segment Gram matrices of ``[1, y, ŷ_forced, free responses]`` (about the first output
    sample), from which the training fit, the fitted initial state and the segments'
    correlations follow exactly: memory ``SEGMENTS · (order + 3)²`` numbers.

    Parameters
    ----------
    model : LinearODEModel
    values : mapping
        Every coefficient's value (SI).
    n_samples : int
        Samples of the part simulated (segments are cut as `linear_ode_problems` cuts them).
    """

    def __init__(self, model, values, n_samples: int):
        self.model = model
        params = {k: float(v) for k, v in values.items() if k in model.parameter_names}
        offset = getattr(model, "output_offset", None)
        self.offset = float(values[offset]) if offset in values else model.known_output_offset()
        n = model.order
        self.forced = _Chain(model, params)
        self.free = [_Chain(model, params, x0=np.eye(n)[k]) for k in range(n)]
        self.edges = np.linspace(0, n_samples, SEGMENTS + 1).astype(int)
        self.gram = np.zeros((SEGMENTS, n + 3, n + 3))
        self.shift = None
        self.seen = 0

    def add(self, t, u, y) -> None:
        """Simulate one block and add its rows to the segments' Gram matrices."""
        if self.shift is None:
            self.shift = float(y[0])
        forced = self.forced.run(t, u) + self.offset
        free = [c.run(t, None) for c in self.free]
        Z = np.column_stack([np.ones(y.size), y - self.shift, forced - self.shift, *free])
        seg = np.searchsorted(self.edges[1:-1], self.seen + np.arange(y.size), side="right")
        with np.errstate(all="ignore"):
            for k in np.unique(seg):
                rows = Z[seg == k]
                self.gram[k] += rows.T @ rows
        self.seen += y.size

    def verdict(self, times, out_name: str, unchanging_sentence: str | None):
        """``(fit [%], problems)``: `_training_fit` and `linear_ode_problems` of the record."""
        gram = self.gram
        G = gram.sum(axis=0)
        if not np.isfinite(G[2, 2]):  # the forced response cannot be simulated: no prediction
            return float("nan"), [unchanging_sentence]
        if not np.all(np.isfinite(np.diag(G)[3:])):  # free responses unusable: x0 = 0
            gram, G = gram[:, :3, :3], G[:3, :3]
        n_state = G.shape[0] - 3
        c_r = np.zeros(n_state + 3)  # r = y − ŷ_forced; x0 = argmin ‖r − F x0‖ (the lstsq)
        c_r[1], c_r[2] = 1.0, -1.0
        x0 = np.linalg.lstsq(G[3:, 3:], G[3:] @ c_r, rcond=None)[0] if n_state else np.zeros(0)
        c_hat = np.zeros(n_state + 3)  # ŷ = ŷ_forced + F x0 (about the shift)
        c_hat[2] = 1.0
        c_hat[3:] = x0
        c_y = np.zeros(n_state + 3)
        c_y[1] = 1.0
        res = c_y - c_hat
        n = G[0, 0]
        spread2 = c_y @ G @ c_y - (G[0] @ c_y) ** 2 / n
        fit = float("nan")
        if spread2 > 0:
            fit = 100.0 * (1.0 - math.sqrt(max(res @ G @ res, 0.0)) / math.sqrt(spread2))
        problems = [unchanging_sentence]
        if unchanging_sentence is None and self.edges[-1] >= 8 * SEGMENTS:
            corr, energy = _segments(gram, c_y, c_hat)
            parts = (times, self.edges, corr, energy)
            label = f"the output {out_name}"
            flip = flipped_segments(None, None, None, name=label, parts=parts)
            problems.append(flip or partial_segments(None, None, None, name=label, parts=parts))
        return fit, problems


def _segments(gram, c_y, c_hat):
    """Correlation of y with ŷ and energy of y (about their means) in each segment."""
    corr = np.full(SEGMENTS, np.nan)
    energy = np.zeros(SEGMENTS)
    for k, G in enumerate(gram):
        n = G[0, 0]
        if n == 0:
            continue
        yy = c_y @ G @ c_y - (G[0] @ c_y) ** 2 / n
        hh = c_hat @ G @ c_hat - (G[0] @ c_hat) ** 2 / n
        yh = c_y @ G @ c_hat - (G[0] @ c_y) * (G[0] @ c_hat) / n
        energy[k] = float(yy)
        den = math.sqrt(max(yy, 0.0) * max(hh, 0.0))
        if den > 0:
            corr[k] = float(yh) / den
    return corr, energy


def refuse(setting: str, value, streams: str, why: str):
    """An `InputError` for a setting that cannot stream, naming the one that does."""
    return InputError(
        f"{arg(setting)}={value!r} cannot be fitted block by block: {why}. Use "
        f"{arg(setting)}={streams!r} for a streamed fit, or fit the record in memory."
    )
