"""Row selection: which equations of a joint with dry friction to drop (IDIM and input-error).

While a joint with Coulomb friction is stuck, the friction torque holding it lies anywhere in
[−Fc, Fc] but the regressor writes Fc·sign(q̇) with a q̇ that is only noise; those equations are
wrong, not noisy, and both inverse-model estimators drop them.

Two rules:

- ``"auto"`` (the default, `sticking_samples`): a joint sticks where the data show it: its
  *measured* position stays within its own noise / quantisation level (`position_noise`) for a
  sustained interval (`STILL_SECONDS`). A smooth motion that merely passes through zero speed
  at a reversal is not sticking and keeps its equations; a record without rests keeps them all.
  The mask is widened only by the main lobes of the state filter and of the parallel filter
  (`contamination_reach`), the samples a sticking interval itself contaminates. Two more kinds
  of equation are *candidates* (`reversal_samples`): those next to a speed reversal, where the
  filters smear the friction step, and those at low speed (|q̇| below `SLOW_FRACTION` of the
  joint's rms speed), where a friction law the model does not have (a Stribeck hump, a
  pre-sliding regime) departs from Fc·sign(q̇) + Fv·q̇. A first fit's residual decides: a
  joint whose candidates fit twice worse than its other equations loses them
  (`elevated_joints`); one whose friction is as modelled keeps them.
- a number F in (0, 1) (`stuck_samples`, the rule of earlier versions): every sample where the
  *filtered* speed is below F times its rms, widened by the parallel filter's full length.

Every Coulomb form a model allows counts (``Fc{j}``, ``Fcp{j}``, ``Fcn{j}``).
"""

from __future__ import annotations

import math
import re

import numpy as np

from ..signals.noise import third_difference_sigma

__all__: list[str] = []

#: The default rule: sticking shown by the data (see the module docstring).
STICK_AUTO = "auto"
#: The speed-fraction rule's usual threshold (``stick_threshold=0.05``).
STICK_THRESHOLD = 0.05
#: A joint sticks when its position stays within its noise band for a sustained interval: long
#: enough that a reversal at a tenth of the joint's rms acceleration would leave the band, at
#: most this long [s] …
STILL_SECONDS = 0.2
#: … and at least this many samples.
STILL_MIN_SAMPLES = 5
#: The noise band: this many robust standard deviations of the position noise (peak to peak).
NOISE_BAND = 8.0
#: A joint that loses more than this share of its equations is named in a warning.
HEAVY_SHARE = 0.5
#: Equations where a dry-friction joint moves slower than this fraction of its rms speed
#: (`coarse_speed_rms`) are candidates, dropped when the residual shows friction the model
#: does not explain there (`reversal_samples`, `elevated_joints`). Measured on data physid did
#: not make (benchmarks/zoo, well-excited base parameters against the truth): a geared arm with
#: a Stribeck hump 7.8 % → 0.26 %, an arm with smoothed Coulomb friction and rests 19 % → 5.1 %,
#: MuJoCo's sticking joints 11.7 % → 10.1 %, a linear drive 0.34 % → 0.20 %; a frictionless arm
#: unchanged (nothing stands out), the slow sweep 3.3 % → 3.2 %. (Measured at the decimation
#: then chosen; with the candidates judged on the most smoothed rows the geared arm and the
#: drive now get 0.44 % and 0.16 %.)
SLOW_FRACTION = 0.2

_COULOMB = re.compile(r"(Fc|Fcp|Fcn)(\d+)")


def coulomb_joints(model) -> np.ndarray:
    """Bool per joint: whether the model has a dry-friction term there (``Fc``, ``Fcp``, ``Fcn``)."""
    nj = int(model.n_joints)
    out = np.zeros(nj, dtype=bool)
    for name in getattr(model, "parameter_names", ()):
        m = _COULOMB.fullmatch(str(name))
        if m and 1 <= int(m[2]) <= nj:
            out[int(m[2]) - 1] = True
    return out


def check_stick_threshold(value, name: str = "stick_threshold"):
    """``"auto"`` or a float in [0, 1); raise `InputError` otherwise."""
    from ..errors import InputError, arg

    if isinstance(value, str):
        if value.strip().lower() == STICK_AUTO:
            return STICK_AUTO
        try:
            value = float(value)
        except ValueError:
            value = float("nan")
    try:
        value = float(value)
    except (TypeError, ValueError):
        value = float("nan")
    if not (np.isfinite(value) and 0.0 <= value < 1.0):
        raise InputError(
            f"{arg(name)} must be 'auto' (drop the equations where the data show sticking) or a "
            f"fraction of the rms speed in [0, 1) (0 keeps every equation); got {value!r}."
        )
    return value


def position_noise(q) -> tuple[np.ndarray, np.ndarray]:
    """Noise level and quantum of each joint's measured position [rad].

    The noise is the robust standard deviation of the third difference divided by √20 (white
    noise of std σ gives Δ³q of std √20·σ; a smooth motion sampled fast gives almost none);
    the quantum is the smallest nonzero |Δq| when the positions sit on a grid (0 otherwise).

    Parameters
    ----------
    q : ndarray, shape (n_samples, n_joints) [rad]

    Returns
    -------
    sigma, quantum : ndarray, shape (n_joints,) [rad]
    """
    q = np.asarray(q, dtype=float)
    sigma = third_difference_sigma(q)
    d1 = np.abs(np.diff(q, axis=0))
    quantum = np.zeros(q.shape[1])
    for j in range(q.shape[1]):  # per joint, not per sample
        nz = d1[:, j][d1[:, j] > 0]
        if nz.size:
            step = float(np.min(nz))
            # on a grid when most steps are whole multiples of the smallest one
            ratio = nz[:2000] / step
            if np.mean(np.abs(ratio - np.round(ratio)) < 1e-3) > 0.9:
                quantum[j] = step
    return sigma, quantum


def sticking_samples(q, dt: float, coulomb) -> np.ndarray:
    """Samples × joints where a joint with dry friction is shown by its position to stick.

    A sample sticks when it lies in a window over which the joint's measured position varies by
    less than its noise band b (``NOISE_BAND`` · σ plus two quanta, `position_noise`). The
    window is T = √(8 b / a) long, with a a tenth of the joint's rms acceleration, so that
    a smooth reversal (q ≈ q₀ + a t²/2, range a T²/8 over T) does not fit in it; T is kept in
    [``STILL_MIN_SAMPLES`` samples, `STILL_SECONDS`]. Vectorised (moving max/min), one window
    length per joint.

    Parameters
    ----------
    q : ndarray, shape (n_samples, n_joints) [rad]
        The measured (unfiltered) positions.
    dt : float [s]
    coulomb : ndarray of bool, shape (n_joints,)

    Returns
    -------
    ndarray of bool, shape (n_samples, n_joints)
    """
    q = np.asarray(q, dtype=float)
    n, nj = q.shape
    coulomb = np.asarray(coulomb, dtype=bool)
    if n < 4 * STILL_MIN_SAMPLES or not np.any(coulomb):
        return np.zeros((n, nj), dtype=bool)
    sigma, quantum = position_noise(q)
    scale = np.max(np.abs(q), axis=0) + 1.0
    h = coarse_step(n, dt)  # a coarse step: the noise barely counts
    acc = (q[2 * h :] - 2.0 * q[h:-h] + q[: -2 * h]) / (h * dt) ** 2
    band, widths = sticking_windows(sigma, quantum, scale, np.mean(acc**2, axis=0), dt)
    return sticking_mask(q, coulomb, band, widths)


def sticking_windows(sigma, quantum, scale, mean_acc2, dt: float):
    """The noise band b [rad] and still-window length T [samples] of each joint.

    ``b = NOISE_BAND·σ + 2·quantum + 1e-12·scale``; ``T = √(8 b / a)`` with a a tenth of the rms
    coarse acceleration (``mean_acc2``: its mean square [rad²/s⁴]), clipped to
    [``STILL_MIN_SAMPLES``, `STILL_SECONDS`]. Shared by `sticking_samples` and the streamed fit
    (which passes whole-record statistics).
    """
    band = NOISE_BAND * np.asarray(sigma) + 2.0 * np.asarray(quantum) + 1e-12 * np.asarray(scale)
    a_ref = 0.1 * np.sqrt(np.asarray(mean_acc2)) + 1e-300
    widths = np.sqrt(8.0 * band / a_ref) / dt
    widths = np.clip(widths, STILL_MIN_SAMPLES, max(STILL_SECONDS / dt, STILL_MIN_SAMPLES))
    return band, widths


def sticking_mask(q, coulomb, band, widths, start: int = 0, n_total: int | None = None):
    """`sticking_samples`' mask of the samples ``start .. start + len(q)`` of a record of
    ``n_total`` samples, given each joint's band and window (`sticking_windows`).

    On a part of a record the mask is exact except within a window length of a cut that is not
    the record's own first or last sample (callers keep that much margin).
    """
    from scipy import ndimage

    n_part, nj = q.shape
    n = n_part if n_total is None else int(n_total)
    out = np.zeros((n_part, nj), dtype=bool)
    for j in np.flatnonzero(coulomb):  # per joint (its own window), vectorised over samples
        w = int(round(widths[j]))
        if n < w or n_part < 1:
            continue
        # window starting at i: [i, i + w); origin shifts the centred filters to that window
        lo = ndimage.minimum_filter1d(q[:, j], w, mode="nearest", origin=-(w // 2))
        hi = ndimage.maximum_filter1d(q[:, j], w, mode="nearest", origin=-(w // 2))
        still = (hi - lo) <= band[j]
        still[max(n - w + 1 - start, 0) :] = False  # windows running past the end
        # every sample of a still window sticks: spread each start over the window it opens
        out[:, j] = ndimage.maximum_filter1d(
            still.astype(np.uint8), w, mode="constant", origin=(w - 1) // 2
        ).astype(bool)
    return out


def contamination_reach(cutoff: float, decimate: int) -> int:
    """Samples on each side of a sticking interval whose rows it contaminates.

    The main lobe of the state filter (half-width π/Ω samples at cut-off Ω rad/sample) and of
    the parallel filter (its cut-off 0.8π/nd: about nd samples), not their full lengths.
    """
    return int(math.ceil(np.pi / float(cutoff))) + (int(decimate) if decimate > 1 else 0)


def dilate(mask, reach: int) -> np.ndarray:
    """``mask`` (n, n_joints) widened by ``reach`` samples on both sides (moving maximum)."""
    if reach <= 0:
        return np.asarray(mask, dtype=bool)
    mask = np.asarray(mask, dtype=bool)
    c = np.concatenate([np.zeros((1, mask.shape[1])), np.cumsum(mask, axis=0)])
    n = mask.shape[0]
    lo = np.clip(np.arange(n) - reach, 0, n)
    hi = np.clip(np.arange(n) + reach + 1, 0, n)
    return (c[hi] - c[lo]) > 0


def stuck_samples(qd, coulomb, threshold: float, reach: int) -> np.ndarray:
    """Samples × joints where a Coulomb joint is at or near rest, widened by ``reach`` samples.

    The speed-fraction rule: ``qd`` (n, n_joints) are the filtered speeds; a sample is near rest
    when |q̇_j| is below ``threshold`` · rms(q̇_j). The mask is dilated by ``reach`` samples on
    both sides. Vectorised: a moving maximum by cumulative sums.
    """
    qd = np.asarray(qd, dtype=float)
    rms = np.sqrt(np.mean(qd**2, axis=0))
    near = (np.abs(qd) < threshold * np.where(rms > 0, rms, 1.0)) & coulomb[None, :]
    return dilate(near, reach)


def reversal_samples(qd, coulomb, reach: int, speed_rms=None) -> np.ndarray:
    """Samples × joints within ``reach`` of a sign change of a dry-friction joint's speed, or
    (with ``speed_rms``) of a sample where it is slower than `SLOW_FRACTION` · ``speed_rms``.

    At a reversal the Coulomb torque jumps by 2·Fc; the filters smear that step over their main
    lobes, so the equations there may be wrong although the joint never sticks. At low speed a
    friction law the model lacks (Stribeck) departs from Fc·sign(q̇). They are only candidates:
    `elevated_joints` decides from the residual whether to drop them.

    Parameters
    ----------
    qd : ndarray, shape (n_samples, n_joints) [rad/s]
        The filtered speeds.
    coulomb : ndarray of bool, shape (n_joints,)
    reach : int
        Samples the mask is widened by on each side.
    speed_rms : ndarray, shape (n_joints,), optional
        Each joint's rms speed over its whole record [rad/s] (`coarse_speed_rms`).

    Returns
    -------
    ndarray of bool, shape (n_samples, n_joints)
    """
    qd = np.asarray(qd, dtype=float)
    coulomb = np.asarray(coulomb, dtype=bool)
    near = np.zeros(qd.shape, dtype=bool)
    near[1:] = np.signbit(qd[1:]) != np.signbit(qd[:-1])
    if speed_rms is not None:
        near |= np.abs(qd) < SLOW_FRACTION * np.asarray(speed_rms, dtype=float)[None, :]
    near &= coulomb[None, :]
    return dilate(near, reach)


def coarse_speed_rms(q, dt: float) -> np.ndarray:
    """rms speed of each joint over a record [rad/s], from a central difference over 0.1 s
    (so that position noise barely counts): what `SLOW_FRACTION` is a fraction of.

    Parameters
    ----------
    q : ndarray, shape (n_samples, n_joints) [rad]
        The measured positions.
    dt : float [s]

    Returns
    -------
    ndarray, shape (n_joints,)
        ``√mean(((q[k+2h] − q[k]) / (2 h dt))²)``, ``h = round(0.05 s / dt)`` (at most n/4); the
        streamed fit's survey accumulates the same sum block by block.
    """
    q = np.asarray(q, dtype=float)
    n = q.shape[0]
    h = coarse_step(n, dt)
    if n <= 2 * h:
        return np.zeros(q.shape[1])
    v = (q[2 * h :] - q[: -2 * h]) / (2 * h * dt)
    return np.sqrt(np.mean(v * v, axis=0))


def coarse_step(n: int, dt: float) -> int:
    """The coarse step h [samples] of `sticking_samples`' acceleration and `coarse_speed_rms`:
    0.05 s, at least 1, at most a quarter of the record."""
    return max(1, min(int(round(0.05 / dt)), n // 4))


def elevated_joints(e, candidate, kept, ratio: float = 2.0, min_rows: int = 10) -> np.ndarray:
    """Bool per joint: are the residuals on the ``candidate`` rows ``ratio`` times the others'?

    ``e`` (n_rows, n_joints) are the residuals of a first fit; ``candidate`` and ``kept``
    (n_rows, n_joints) of bool. A joint whose candidate equations fit no worse than the rest
    keeps them (a frictionless plant, a smooth friction law); one whose reversals leave a
    residual ``ratio`` times larger (rms) drops them.
    """
    e = np.asarray(e, dtype=float)
    cand = candidate & kept
    rest = ~candidate & kept
    n_c, n_r = cand.sum(axis=0), rest.sum(axis=0)
    rms_c = np.sqrt(np.sum(np.where(cand, e**2, 0.0), axis=0) / np.maximum(n_c, 1))
    rms_r = np.sqrt(np.sum(np.where(rest, e**2, 0.0), axis=0) / np.maximum(n_r, 1))
    return (n_c >= 1) & (n_r >= min_rows) & (rms_c > ratio * rms_r)


def drop_equations(W, tau, stuck) -> tuple[np.ndarray, np.ndarray]:
    """Zero, in place, the equations marked ``stuck``: no information, no weight.

    ``W`` (n, n_joints, p) and ``tau`` (n, n_joints) are the rows of a regression
    ``τ = W β``; ``stuck`` (n, n_joints) of bool. A zeroed equation adds nothing to the normal
    equations, so the least-squares solution is that of the equations kept. Returns ``(W, tau)``.
    """
    W[stuck] = 0.0
    tau[stuck] = 0.0
    return W, tau


def dropped_summary(stuck, rule, fix: str | None = None, candidates=None) -> tuple[str, list[str]]:
    """One sentence on the equations dropped per joint, and a warning per heavily hit joint.

    Parameters
    ----------
    stuck : ndarray of bool, shape (n_rows, n_joints), or None
    rule : "auto" or float
        The ``stick_threshold`` that made it.
    fix : str, optional
        How to keep the equations (default: ``stick_threshold=0``, which the command line words
        as ``--stick-threshold 0``).
    candidates : ndarray of bool, shape (n_rows, n_joints), optional
        The candidates of the residual test (`reversal_samples`): the dropped equations among
        them are counted apart from those of sticking.

    Returns
    -------
    sentence : str
        Empty when nothing was dropped.
    warnings : list of str
        One per joint that lost more than `HEAVY_SHARE` of its equations, with the fix.
    """
    if stuck is None or not np.any(stuck):
        return "", []
    by_residual = None if candidates is None else (stuck & candidates).sum(axis=0)
    return dropped_summary_counts(stuck.sum(axis=0), stuck.shape[0], rule, fix, by_residual)


def dropped_summary_counts(counts, n_rows: int, rule, fix: str | None = None, by_residual=None):
    """`dropped_summary` from the equations dropped per joint (``counts``) of ``n_rows`` rows,
    ``by_residual`` of them (per joint) by the residual test."""
    counts = np.asarray(counts, dtype=int)
    if not np.any(counts):
        return "", []
    share = counts / float(n_rows)
    residual = np.zeros_like(counts) if by_residual is None else np.asarray(by_residual, int)
    sticking = counts - residual
    if rule == STICK_AUTO:
        kinds = []
        if np.any(sticking):
            kinds.append(
                (
                    int(sticking.sum()),
                    "where the joint sticks (its measured position within its noise for a "
                    "sustained interval: the holding friction is unknown)",
                )
            )
        if np.any(residual):
            joints = ", ".join(str(j + 1) for j in np.flatnonzero(residual))
            kinds.append(
                (
                    int(residual.sum()),
                    f"next to a speed reversal or below {SLOW_FRACTION:g}× the joint's rms speed "
                    "(widened by the filters' main lobes), where a first fit's residual was more "
                    "than twice the others' (friction the model lacks, or the filters' smear of "
                    f"the friction step at stops and reversals; joint(s) {joints})",
                )
            )
        how = (
            f" {kinds[0][1]}"
            if len(kinds) == 1
            else ": " + "; ".join(f"{n} {text}" for n, text in kinds)
        )
    else:
        how = f" near rest (at |q̇| < {float(rule):g}·rms)"
    per = ", ".join(f"joint {j + 1} {100 * s:.0f} %" for j, s in enumerate(share) if s > 0)
    sentence = (
        f" {int(counts.sum())} of {n_rows * counts.size} joint equations dropped{how}. "
        f"Per joint: {per}."
    )
    fix = fix or "keep them with stick_threshold=0"
    heavy = []
    for j in np.flatnonzero(share > HEAVY_SHARE):
        lost = f"joint {j + 1} lost {100 * share[j]:.0f} % of its equations to the stiction rule"
        if rule != STICK_AUTO:
            heavy.append(
                f"{lost} (speed below {float(rule):g}·rms); if the joint does not really stick "
                f"there, {fix}."
            )
        elif residual[j] * 2 >= counts[j]:  # mostly the residual test's
            heavy.append(
                f"{lost}, most where a first fit's residual stood out next to speed reversals or "
                "at low speed (friction the model lacks, e.g. a Stribeck hump, or the filters' "
                "smear of the friction step): they are left out on purpose, and keeping them "
                "(stick_threshold=0) brings that error into the estimate; a longer or "
                "faster-moving record keeps more."
            )
        else:
            heavy.append(
                f"{lost} (sustained sticking); if the joint does not really stick there, {fix}."
            )
    return sentence, heavy


def never_moving(moving) -> list[str]:
    """A warning per joint that never moves (named, with the fix): the fits' one wording.

    Parameters
    ----------
    moving : array_like of bool, shape (n_joints,)
        Whether each joint leaves its noise band in some recording (`motionless_joints`).

    Returns
    -------
    list of str
    """
    return [
        f"joint {j + 1} never moves in the recording(s) (its position stays within its noise): "
        "its own parameters are identified only through the other joints' motion, if at all, "
        "and its torque equations carry no information on its friction; move it in the "
        "experiment (physid design-excitation) or fix its parameters in the model."
        for j in np.flatnonzero(~np.asarray(moving, dtype=bool))
    ]


def motionless_joints(q) -> np.ndarray:
    """Bool per joint: its measured position never leaves its noise band over the record.

    Parameters
    ----------
    q : ndarray, shape (n_samples, n_joints) [rad]

    Returns
    -------
    ndarray of bool, shape (n_joints,)
    """
    q = np.asarray(q, dtype=float)
    if q.shape[0] < 8:
        return np.zeros(q.shape[1], dtype=bool)
    sigma, quantum = position_noise(q)
    band = NOISE_BAND * sigma + 2.0 * quantum + 1e-12 * (np.max(np.abs(q), axis=0) + 1.0)
    return (np.max(q, axis=0) - np.min(q, axis=0)) <= band
