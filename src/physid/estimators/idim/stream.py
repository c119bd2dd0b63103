"""IDIM over records of any length in bounded memory: streamed, equal to the in-memory fit.

`fit_streamed` reads each record (a block source, `physid.signals.blocks`, or a `Recording`)
twice, block by block, and never holds its regressor:

1. `plan_streamed` (`.stream_plan`): a survey pass over the q and tau channels: length, period,
   the state-filter cut-off (``"auto"``: the first record's Welch spectrum, segment by segment
   as `auto_cutoff` computes it), the robust noise statistics, the candidate decimations;
2. `idim_moments` (`.stream_moments`, `.stream_window`): the main pass: windows of
   ``block_samples`` full-rate samples with the filters' margins give exactly the in-memory
   rows (state filter, base regressor, parallel filter and decimation, stiction masks; the
   parallel filter's forward pass carried from window to window, `.stream_filter`); their
   per-fold, per-joint QR factors, lagged products and a thinned sample are accumulated;
3. `fit_moments` (`.stream_fit`): the cross-validated choice of nd, OLS/WLS, the covariance
   (``stderr`` "filtered" or "iid"), the condition number and the verdict.

Moments of several sources merge exactly (``+``), so a fit over many records can be a
map-reduce: ``fit_moments(model, plan, sum(idim_moments(model, plan, s, k) for k, s in …))``.

What equals the in-memory fit and what does not: the rows, estimate, standard errors,
condition number, relative errors, cut-off, half-width and decimation are the same (to rounding:
the estimate to ~1e-12 relative on well-conditioned data). The noise statistics that are
whole-record medians in memory (position and torque noise: the sticking rule, the noise floor of
the verdict, still joints) are medians of per-block estimates (blocks of at least 65536 samples:
identical for shorter records). ``stderr="hac"`` and ``method="iv"`` are refused. The result's
``t``/``residuals`` hold at most 20 000 rows (every k-th).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from .stream_fit import fit_moments
from .stream_moments import RowMoments, idim_moments
from .stream_plan import StreamPlan, _as_sources, plan_from_surveys, plan_streamed, survey_source
from .stream_window import Margins, RawReader, windows

__all__ = [
    "fit_streamed",
    "plan_streamed",
    "idim_moments",
    "RowMoments",
    "fit_moments",
    "StreamPlan",
    "survey_source",
    "plan_from_surveys",
    "speed_rms",
    "scale_gate",
    "in_memory_peak",
    "streams_better",
    "stream_obstacle",
    "STREAMED_SETTINGS",
]

#: The `IDIMEstimator` settings `fit_streamed` takes (the others concern IV or ``consistent``).
STREAMED_SETTINGS = (
    "differentiation",
    "cutoff",
    "half_width",
    "decimate",
    "stderr",
    "per_joint_variance",
    "stick_threshold",
    "check_condition",
)
#: The in-memory fit holds about this many copies of the full-rate regressor at its peak.
COPIES_IN_MEMORY = 3


def fit_streamed(
    model,
    sources,
    *,
    method: str = "ols",
    differentiation: str = "physid",
    cutoff: float | str = "auto",
    half_width: int | None = None,
    decimate: int | str = "auto",
    stderr: str = "filtered",
    per_joint_variance: bool = True,
    stick_threshold: float | str = "auto",
    check_condition: bool = True,
    block_samples: int = 65536,
    progress: bool = True,
    timings: dict | None = None,
):
    """IDIM-OLS or -WLS of one or several records read block by block, in bounded memory.

    Parameters
    ----------
    model : ChainModel
        Linear in its base parameters.
    sources : BlockSource, Recording, or a sequence of them
        ``q1..qn`` [rad], ``tau1..taun`` [N·m]; several are several experiments (as
        `IDIMEstimator.fit` of a list: one cut-off from the first, the half-width and the
        candidate decimations from the shortest, no filter across two records).
    method : {"ols", "wls"}
    differentiation, cutoff, half_width, decimate, stderr, per_joint_variance, stick_threshold,
    check_condition
        As `IDIMEstimator` (``stderr``: "filtered" or "iid").
    block_samples : int
        Samples read and filtered at a time.
    progress : bool
        Show samples read and time left on stderr (silent off a terminal).
    timings : dict, optional
        Filled with seconds spent in read, state filter, regressor, parallel filter,
        accumulate, survey and solve.

    Returns
    -------
    IDIMResult
        As ``IDIMEstimator(model, method, ...).fit(recordings).result_``; ``t`` and
        ``residuals`` hold at most 20 000 of the decimated rows (every k-th, said in the
        warnings).

    Raises
    ------
    InputError
        ``method="iv"`` or ``stderr="hac"`` (named with the alternatives), bad settings,
        missing channels, a NaN in a record.
    SamplingError, ShapeError
        Records with other periods or joints than the first (named), too short records.
    IdentifiabilityError
        An unexcited base parameter, or a condition number above 1e8.

    Notes
    -----
    Peak memory, independent of the record's length: about
    ``max(block_samples + M + L, 1.5 · block_samples + M) · (n_joints · p + n_joints) · 8``
    bytes of full-rate rows, the longest window's (M: the left margin, ~12·nd full-rate
    samples, the masks' reach and the parallel filter's end padding; L: the parallel filter's
    right margin, ~95·nd full-rate samples, whose forward pass is carried to the next window;
    the last window is up to 1.5 steps long, plus the left margin), the parallel filter's
    temporaries (lifted in place, from nd = 40 on: ~25/nd of a window's rows; below, a copy of
    up to 96 columns of the window, and about three more where ``sosfilt`` runs on every
    sample; an nd = 1 candidate: a copy of a step's rows), plus
    ``n_candidates · (10 · n_joints · (p+1)² + 2 · n_joints · p²) · 8`` bytes of accumulators and
    ``20000 · n_joints · (p+1) · 8`` bytes of kept rows per candidate.

    Examples
    --------
    >>> # result = fit_streamed(physid.load_model("arm6"), physid.signals.io.open_blocks(path))
    """
    from ..._progress import Progress

    times = {} if timings is None else timings
    tic = time.perf_counter()
    srcs = _as_sources(sources, _as_block)
    settings = dict(
        method=method,
        differentiation=differentiation,
        cutoff=cutoff,
        half_width=half_width,
        decimate=decimate,
        stderr=stderr,
        per_joint_variance=per_joint_variance,
        stick_threshold=stick_threshold,
        check_condition=check_condition,
        block_samples=block_samples,
    )
    plan = plan_streamed(model, srcs, **settings)
    if isinstance(plan.stick, float):
        plan = dataclasses.replace(plan, qd_rms=speed_rms(model, plan, srcs))
    times["survey"] = times.get("survey", 0.0) + time.perf_counter() - tic
    total = sum(plan.lengths)
    bar = Progress(total, "streamed IDIM", unit="samples", stream=None)
    bar.enabled = bar.enabled and bool(progress)
    moments = None
    with bar:
        for k, src in enumerate(srcs):
            m = idim_moments(model, plan, src, k, timings=times, progress=bar)
            moments = m if moments is None else moments + m
    tic = time.perf_counter()
    result = scale_gate(model, fit_moments(model, plan, moments), srcs)
    times["solve"] = times.get("solve", 0.0) + time.perf_counter() - tic
    return result


def scale_gate(model, result, sources):
    """The result with the plausibility gate's scale check applied, as `IDIMEstimator` does.

    Estimates 100× away from the model's nominal masses fail the fit
    (`physid.estimators.plausibility.implausible_scale`); the sources' first samples carry the
    units and metadata the check names as suspects.

    Parameters
    ----------
    model : ChainModel
    result : IDIMResult
        From `fit_moments`.
    sources : sequence of BlockSource

    Returns
    -------
    IDIMResult
        ``result`` itself, or a copy with ``success`` False and the reason in ``message``.
    """
    from ..plausibility import gate, implausible_scale

    firsts = [next(iter(s.blocks(2))) for s in sources]
    scale = implausible_scale(dict(result.parameters), model, firsts)
    if not scale:
        return result
    success, message = gate(result.success, result.message, scale)
    return dataclasses.replace(result, success=success, message=message)


def _as_block(obj):
    from ...signals.blocks import as_block_source

    return as_block_source(obj)


def speed_rms(model, plan: StreamPlan, sources) -> np.ndarray:
    """rms of the filtered speed per source [rad/s] (the speed-fraction stiction rule): a pass
    of the state filter alone.

    Parameters
    ----------
    model : ChainModel
    plan : StreamPlan
    sources : sequence of BlockSource
        In the plan's order.

    Returns
    -------
    ndarray, shape (n_sources, n_joints)
    """
    from .stream_window import _states

    mg = Margins(plan)
    nj = plan.n_joints
    chans = [f"q{j + 1}" for j in range(nj)]
    out = []
    for k, src in enumerate(sources):
        reader = RawReader(src, chans, plan.block_samples)
        total = np.zeros(nj)
        for a, b, _c0, _c1, r0, r1 in windows(plan, k, mg):
            _, q = reader.get(r0, r1)
            _, qd, _ = _states(plan, q, r0, a, b)
            total += np.sum(qd**2, axis=0)
        out.append(np.sqrt(total / plan.n_stacked(k)))
    return np.array(out)


def in_memory_peak(paths, model, *, topic=None) -> int:
    """Estimated peak memory [bytes] of the in-memory IDIM fit of the files ``paths``.

    The raw record (`physid.signals.io.in_memory_bytes`) plus `COPIES_IN_MEMORY` copies of the
    full-rate regressor, ``n_samples × n_joints × n_parameters × 8`` bytes (the standard
    parameters bound the base ones), for the largest file. The samples are a ROS bag's message
    count from its index (`physid.signals.io.in_memory_extent`), else bounded by the raw bytes
    over ``8 × (2 n_joints + 1)`` (t, q and tau at least).

    Parameters
    ----------
    paths : sequence of str or Path
    model : ChainModel
    topic : str, optional
        A ROS bag's topic(s) (``--topic``).

    Returns
    -------
    int
    """
    from ...signals.io import in_memory_extent

    nj = int(model.n_joints)
    n_par = len(getattr(model, "parameter_names", ())) or 10 * nj
    peak = 0
    for p in paths:
        raw, n_samples = in_memory_extent(p, topic)  # a bag opened once
        if n_samples is None:
            n_samples = raw // (8 * (2 * nj + 1))  # t, q1..qn, tau1..taun at least
        peak = max(peak, raw + COPIES_IN_MEMORY * n_samples * nj * n_par * 8)
    return int(peak)


def streams_better(paths, model, *, workers: int = 1, topic=None) -> tuple[bool, int, int]:
    """Whether the files are better fitted block by block: ``(stream, peak, limit)`` [bytes].

    True when `in_memory_peak` exceeds `physid._resources.stream_limit` (2 GiB, or a quarter of
    the available memory shared by ``workers`` processes when that is less).

    Parameters
    ----------
    paths : sequence of str or Path
    model : ChainModel
    workers : int
        Processes fitting at the same time (a fleet's workers share the memory).
    topic : str, optional
        A ROS bag's topic(s) (``--topic``).

    Returns
    -------
    stream : bool
    peak, limit : int
        The estimate and the limit it was compared with.
    """
    from ..._resources import stream_limit

    peak = in_memory_peak(paths, model, topic=topic)
    limit = stream_limit(workers)
    return peak > limit, peak, limit


def stream_obstacle(
    method: str,
    paths,
    *,
    stderr: str = "filtered",
    consistent: bool = False,
    resample: bool = False,
    join: bool = False,
    detrend=None,
    joints=None,
    torque: str = "measured",
    topic=None,
) -> str | None:
    """Why a fit of the files ``paths`` with these settings cannot stream, or None.

    The one rule `physid identify --stream` and fleets (`physid.analysis.fleet`) follow: only
    IDIM-OLS and IDIM-WLS stream, with settings that need no whole record, on files that can be
    read in blocks.

    Parameters
    ----------
    method : str
        ``"idim-ols"``, ``"idim-wls"``, ``"idim-iv"``, ``"input-error"`` ...
    paths : sequence of str or Path
        The record files.
    stderr, consistent : as `IDIMEstimator`
    resample, join, detrend, joints, torque : as `physid.load_recording` and `physid identify`
        (reading options that act on the whole record).
    topic : str, optional
        A ROS bag's topic (`physid.load_recording`): several comma-separated topics are joined
        on their stamps, which does not stream (`physid.signals.io.block_readers.
        blocks_obstacle`, the files' rule).

    Returns
    -------
    str or None
        The reason, its settings marked with `physid.errors.arg` (so that the command line
        shows its flags), or None when the fit can stream.
    """
    from ...errors import arg
    from ...signals.io.block_readers import blocks_obstacle

    if method not in ("idim-ols", "idim-wls"):
        return (
            f"{arg('method', repr(method), cli=method)} reads the whole record (streamed: "
            "idim-ols, idim-wls)"
        )
    whole = [
        (join, "join", "", "joins whole files on their stamps"),
        (detrend, "detrend", "", "subtracts the mean of the whole record"),
        (joints, "joints", None, "(a subtree of the model) holds the other joints at the "
         "logged positions of the whole record"),
        (stderr == "hac", "stderr", ("'hac'", "hac"), "estimates the residual's correlation "
         "from the whole residual"),
        (consistent, "consistent", "", "fits the consistent estimate on every row"),
        (resample, "resample", "", "interpolates the whole record"),
        (torque != "measured", "torque", (repr(torque), torque), "rebuilds the torques of the "
         "whole record"),
    ]  # fmt: skip
    for present, name, value, why in whole:
        if present:
            shown = (
                arg(name)
                if value is None
                else arg(name, "True", cli="")
                if value == ""
                else arg(name, value[0], cli=value[1])
            )
            return f"{shown} {why}"
    for p in paths:
        why = blocks_obstacle(p, topic)
        if why is not None:
            return why
    return None
