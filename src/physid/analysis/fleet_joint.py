"""One IDIM fit over many logs, computed as a map-reduce on a Dask cluster.

The logs of one robot (or of robots meant to be one) are one fit: their rows stack as
experiments, as `physid.estimators.idim.IDIMEstimator.fit` stacks a list of recordings. Spread
over a cluster it is two map steps and two reductions, each log read where it is:

1. map: each worker surveys its log (`physid.estimators.idim.stream.survey_source`: length,
   period, noise statistics, the first log's spectrum); reduce: the plan (cut-off, half-width,
   candidate decimations: `plan_from_surveys`);
2. map: each worker reads its log block by block into the moments of its rows
   (`idim_moments`: per-joint QR factors, lagged products, never the rows); reduce: their sum
   (exact), solved once (`fit_moments`).

The result equals the in-memory fit of the same logs (to rounding; see
`physid.estimators.idim.stream` for what is a per-block median there). What travels is small:
the surveys and the moments, a few p × p matrices per log and joint. A worker that dies has its
task rerun (``retries``); a log that cannot be read fails the fit, naming the log.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import time
from collections.abc import Mapping, Sequence

from ..errors import InputError, PhysidError, arg
from ..estimators.idim.stream import STREAMED_SETTINGS
from ..signals.joint_side import joint_side_blocks
from .fleet import _cached_model, _local_kind
from .sweep_backends import (
    SCHEDULER_TIMEOUT,
    dask_client,
    parse_scheduler,
)

__all__ = ["run_joint", "JOINT_SETTINGS"]

#: `IDIMEstimator` settings a joint fit over a cluster takes (it streams each log).
JOINT_SETTINGS = STREAMED_SETTINGS


def _survey_task(model_ref, model_options, load_options, cutoff, block_samples, item):
    """Map step 1 on a worker: ``(names, survey)`` of log ``k`` at ``path``."""
    from ..estimators.idim.stream import survey_source
    from ..signals.io import open_blocks

    k, path = item
    model = _cached_model(model_ref, model_options)
    with open_blocks(path, **load_options) as raw:
        src = joint_side_blocks(model, raw)  # motor-side channels through the transmission
        survey = survey_source(
            model, src, k, spectrum=k == 0 and cutoff == "auto", block_samples=block_samples
        )
        return tuple(src.names), survey


def _moments_task(model_ref, model_options, load_options, plan, item):
    """Map step 2 on a worker: the moments of log ``k`` at ``path``."""
    from ..estimators.idim.stream import idim_moments
    from ..signals.io import open_blocks

    k, path = item
    model = _cached_model(model_ref, model_options)
    with open_blocks(path, **load_options) as raw:
        return idim_moments(model, plan, joint_side_blocks(model, raw), k)


class _Failed:
    """A task's `PhysidError`, returned as a value: a worker neither logs it as a crash nor has
    it retried (it would fail again the same way); the client raises it."""

    def __init__(self, error: PhysidError):
        self.error = error


def _returning_errors(task, item):
    """``task(item)``, or `_Failed` holding the `PhysidError` it raised."""
    try:
        return task(item)
    except PhysidError as exc:
        return _Failed(exc)


def _raise_failed(results: list) -> list:
    """``results``, or the first `_Failed` one's error raised."""
    for r in results:
        if isinstance(r, _Failed):
            raise r.error
    return results


@contextlib.contextmanager
def _mapper(scheduler, n_logs: int, retries: int, timeout: float):
    """``(map, backend)``: ``map(task, items) -> list`` in order, on the chosen backend."""
    kind, address = parse_scheduler(scheduler)
    if kind == "local":
        kind, address = _local_kind(n_logs)
    if kind == "serial":
        yield (lambda task, items: [task(x) for x in items]), "serial (in-process)"
        return
    with dask_client(kind, address, timeout) as (client, backend):

        def run(task, items):
            wrapped = functools.partial(_returning_errors, task)
            futures = client.map(wrapped, list(items), retries=int(retries), pure=False)
            try:
                return _raise_failed(client.gather(futures))  # in order; the first error
            except BaseException:
                client.cancel(futures)
                raise

        yield run, backend


def run_joint(
    model_ref,
    paths: Sequence,
    *,
    method: str = "idim-ols",
    fit_options: Mapping | None = None,
    load_options: Mapping | None = None,
    scheduler="local",
    retries: int = 2,
    model_options: Mapping | None = None,
    scheduler_timeout: float = SCHEDULER_TIMEOUT,
    block_samples: int = 65536,
):
    """One IDIM fit over all ``paths``, as a map-reduce of their moments on a Dask cluster.

    Parameters
    ----------
    model_ref : str or Path
        A built-in model name or a model file (loaded once per worker).
    paths : sequence of str or Path
        The logs (files `physid.signals.io.open_blocks` reads), stacked as experiments.
    method : {"idim-ols", "idim-wls"}
    fit_options : mapping, optional
        `IDIMEstimator` keywords among `JOINT_SETTINGS`.
    load_options : mapping, optional
        `physid.signals.io.open_blocks` keywords (channel map, rate, ...).
    scheduler : str or distributed.Client
        ``"serial"``, ``"local"``, ``"local:N"``, ``"tcp://HOST:PORT"`` or a Client (as
        `physid.analysis.fleet.run_fleet`).
    retries : int
        Times Dask reruns a task whose worker died (a log's `PhysidError` is raised at once).
    model_options : mapping, optional
        `physid.load_model` keywords.
    scheduler_timeout : float [s]
        How long a ``tcp://`` scheduler may take to answer.
    block_samples : int
        Samples each worker reads at a time.

    Returns
    -------
    IDIMResult
        With ``n_recordings`` = the number of logs; its ``message`` names the backend.

    Raises
    ------
    InputError
        An empty ``paths``, a method other than OLS/WLS, a setting a joint fit does not take,
        ``resample=True`` in ``load_options``.
    PhysidError
        A log that cannot be read or does not fit with the others (named).
    SchedulerError
        A scheduler address that does not answer.
    """
    from ..estimators.idim.stream import fit_moments, plan_from_surveys, scale_gate, speed_rms
    from ..signals.io import open_blocks

    paths = [str(p) for p in paths]
    if not paths:
        raise InputError(f"{arg('paths')} must name at least one log; got none.")
    if method not in ("idim-ols", "idim-wls"):
        raise InputError(
            f"{arg('method')} of a joint fit over a cluster must be idim-ols or idim-wls (the "
            f"fit is a sum of each log's normal equations); got {method!r}."
        )
    fit_options = dict(fit_options or {})
    other = sorted(set(fit_options) - set(JOINT_SETTINGS))
    if other:
        raise InputError(
            f"a joint fit over a cluster takes {', '.join(JOINT_SETTINGS)}; not {other}."
        )
    load = dict(load_options or {})
    if load.pop("resample", None):
        raise InputError(
            f"{arg('load_options')} holds resample=True, but a joint fit over a cluster reads "
            "each log block by block and cannot interpolate a whole record; resample the logs "
            "first, or fit them in memory (IDIMEstimator.fit of the loaded recordings)."
        )
    opts = dict(model_options or {})
    settings = {**fit_options, "method": method.removeprefix("idim-")}
    settings["block_samples"] = int(block_samples)
    cutoff = fit_options.get("cutoff", "auto")
    model = _cached_model(model_ref, opts)
    items = list(enumerate(paths))
    start = time.perf_counter()
    with _mapper(scheduler, len(paths), retries, scheduler_timeout) as (mapped, backend):
        survey = functools.partial(_survey_task, model_ref, opts, load, cutoff, block_samples)
        surveyed = mapped(survey, items)
        names = [n for n, _ in surveyed]
        plan = plan_from_surveys(model, names, [s for _, s in surveyed], **settings)
        if isinstance(plan.stick, float):  # the speed-fraction rule needs the speed's rms
            sources = [joint_side_blocks(model, open_blocks(p, **load)) for p in paths]
            try:
                plan = dataclasses.replace(plan, qd_rms=speed_rms(model, plan, sources))
            finally:
                for s in sources:
                    s.close()
        moments = mapped(functools.partial(_moments_task, model_ref, opts, load, plan), items)
    total = moments[0]
    for m in moments[1:]:
        total = total + m
    result = fit_moments(model, plan, total)
    with open_blocks(paths[0], **load) as first:
        result = scale_gate(model, result, [joint_side_blocks(model, first)])
    elapsed = time.perf_counter() - start
    note = f" Fitted as a map-reduce over {len(paths)} logs on {backend} in {elapsed:.1f} s."
    return dataclasses.replace(result, message=result.message + note)
