"""Fleets of logs: one IDIM fit per log, run in this process or on a Dask cluster.

A fleet operator re-identifies many robots of one model, one log each; `run_fleet` fits every log
on its own (`fit_one_log`: `physid.load_recording` and `IDIMEstimator`), in the order of the
paths, and returns a `FleetResult` (one row per log, the failed ones with the reason). The work is
spread over Dask with the sweeps' conventions (`physid.analysis.sweep_backends.parse_scheduler`):
``"serial"``, ``"local"``, ``"local:N"`` (a LocalCluster of N single-threaded worker processes),
``"tcp://HOST:PORT"`` (a running scheduler) or a ``distributed.Client``. Tasks are submitted with
``retries`` and ``pure=False``: a task whose worker dies is rerun by the scheduler, so a killed
worker loses no row.

The model travels to the workers as its name or file path and is loaded once per worker process
(`_cached_model`), never pickled. A log's failure (unreadable, too short, not excited, any
`physid.errors.PhysidError`, or an unexpected exception, named by its type) is a failed row; it
never stops the others.
"""

from __future__ import annotations

import functools
import math
import os
import time
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .._validate import check_int, check_positive
from ..errors import InputError, PhysidError, arg
from .fleet_result import FleetResult, read_reference
from .sweep_backends import (
    SCHEDULER_TIMEOUT,
    _import_distributed,
    dask_client,
    parse_scheduler,
)

__all__ = ["run_fleet", "fit_one_log", "FLEET_METHODS"]

#: The per-log fit methods of a fleet (IDIM: models linear in their parameters).
FLEET_METHODS = ("idim-ols", "idim-wls", "idim-iv")
#: Fleets of at most this many logs run in-process under scheduler="local" (a cluster costs more).
IN_PROCESS_LIMIT = 2

_MODELS: dict[tuple, Any] = {}  # one loaded model per (reference, options), per process


def _cached_model(model_ref: str, model_options: Mapping | None):
    """The model ``model_ref`` loaded once per process (a worker fits many logs with it)."""
    from ..models import load_model

    key = (str(model_ref), tuple(sorted((model_options or {}).items())))
    if key not in _MODELS:
        _MODELS[key] = load_model(str(model_ref), **dict(model_options or {}))
    return _MODELS[key]


def _empty_row(path) -> dict:
    return {
        "log": str(path),
        "status": "failed",
        "reason": "",
        "n_samples": None,
        "duration": None,
        "dt": None,
        "success": None,
        "relative_error": None,
        "condition_number": None,
        "cutoff": None,
        "decimate": None,
        "elapsed_s": None,
        "result": None,
    }


def _check_log_path(path) -> None:
    """A missing file or a folder in the list: the log's own failure, worded for it."""
    from ..errors import DataFileError
    from ..signals.io.rosbag_reader import is_rosbag

    p = Path(path)
    if not p.exists():
        raise DataFileError(f"no such file {str(p)!r}; check the path (a log of the fleet).")
    if p.is_dir() and not is_rosbag(p):  # a ROS 2 bag is a folder
        raise DataFileError(f"{str(p)!r} is a folder, not a log file; list the files in it.")


def fit_one_log(
    model_ref,
    path,
    method: str = "idim-ols",
    fit_options: Mapping | None = None,
    load_options: Mapping | None = None,
    *,
    model_options: Mapping | None = None,
    flags: Mapping[str, str | None] | None = None,
    workers: int = 1,
) -> dict:
    """Fit one log of a fleet; never raises for a problem of the log (a failed row instead).

    Parameters
    ----------
    model_ref : str or Path
        A built-in model name or a model file path (loaded once per process).
    path : str or Path
        The log: any file `physid.load_recording` reads.
    method : {"idim-ols", "idim-wls", "idim-iv"}
    fit_options : mapping, optional
        Keywords of `physid.estimators.idim.IDIMEstimator` (cutoff, decimate, stderr, ...).
    load_options : mapping, optional
        Keywords of `physid.load_recording` (channel map, rate, resample, ...).
    model_options : mapping, optional
        Keywords of `physid.load_model` (``kinetic``, ...).
    flags : mapping, optional
        Python keyword → command-line flag, to word a failure's reason for the command line
        (`physid.errors.PhysidError.render`).
    workers : int
        Fits running at the same time on this machine: a log streams (is read block by block)
        when its in-memory fit would need more than a quarter of the free memory shared by them
        (`physid.estimators.idim.stream.streams_better`).

    Returns
    -------
    dict
        A plain, picklable row: ``log``, ``status`` ("ok" | "failed"), ``reason``,
        ``n_samples``, ``duration`` [s], ``dt`` [s], ``success``, ``relative_error``,
        ``condition_number``, ``cutoff`` [rad/sample], ``decimate``, ``elapsed_s`` [s],
        ``NAME`` and ``NAME_se`` for each base parameter, ``warnings`` (text) and ``result``
        (the result's ``to_dict()``, for its result file; None when the fit failed).
    """
    start = time.perf_counter()
    row = _empty_row(path)
    try:
        row.update(_fit(model_ref, path, method, fit_options, load_options, model_options, workers))
        row["status"] = "ok"
    except PhysidError as exc:
        row["reason"] = exc.render(flags)
    except MemoryError:
        row["reason"] = "out of memory fitting this log; fit it alone, or with fewer workers."
    except Exception as exc:  # an unexpected error of one log must not stop the fleet
        row["reason"] = f"unexpected {type(exc).__name__}: {exc}"
    row["elapsed_s"] = time.perf_counter() - start
    return row


def _fit(model_ref, path, method, fit_options, load_options, model_options, workers=1) -> dict:
    """The fit of `fit_one_log`: load the log, fit, and the row's numbers (raises on failure)."""
    from ..estimators.idim import IDIMEstimator
    from ..signals import load_recording
    from ..signals.io.rosbag_reader import is_rosbag
    from ..signals.joint_side import joint_side

    model = _cached_model(model_ref, model_options)
    _check_log_path(path)
    if _streamable(path, model, method, fit_options, load_options, workers):
        result, n, duration, caught = _fit_streamed(model, path, method, fit_options, load_options)
    else:
        load = dict(load_options or {})
        if is_rosbag(path):
            # a bag's stamps jitter: onto its mean period, as identify, unless the caller chose
            load.setdefault("resample", True)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            rec = joint_side(model, load_recording(path, **load))
            est = IDIMEstimator(model, method.removeprefix("idim-"), **dict(fit_options or {}))
            est.fit(rec)
        result, n, duration = est.result_, int(rec.n_samples), float(rec.t[-1] - rec.t[0])
    out: dict[str, Any] = {
        "n_samples": n,
        "duration": duration,
        "dt": float(result.dt),
        "success": bool(result.success),
        "relative_error": _float(result.relative_error.get("overall")),
        "condition_number": _float(result.condition_number),
        "cutoff": _float(result.cutoff),
        "decimate": int(result.decimate),
        "reason": "" if result.success else str(result.message),
        "warnings": "; ".join(dict.fromkeys(str(w.message) for w in caught)),
    }
    for name in result.names:
        out[name] = _float(result.parameters[name])
        out[name + "_se"] = None if result.stderr is None else _float(result.stderr[name])
    out["result"] = result.to_dict()
    return out


def _streamable(path, model, method, fit_options, load_options, workers=1) -> bool:
    """A log too large for an in-memory fit, whose fit and file can stream."""
    from ..estimators.idim.stream import stream_obstacle, streams_better

    fit_options, load_options = dict(fit_options or {}), dict(load_options or {})
    obstacle = stream_obstacle(
        method,
        [path],
        stderr=fit_options.get("stderr", "filtered"),
        consistent=bool(fit_options.get("consistent")),
        resample=bool(load_options.get("resample")),
        topic=load_options.get("topic"),
    )
    if obstacle is not None:
        return False
    try:
        topic = load_options.get("topic")  # a bag by its index's message count, as identify
        return streams_better([path], model, workers=workers, topic=topic)[0]
    except PhysidError:
        return False  # the in-memory load says what is wrong with the file


def _fit_streamed(model, path, method, fit_options, load_options):
    """A long log fitted block by block: ``(result, n_samples, duration, caught warnings)``."""
    from ..estimators.idim.stream import STREAMED_SETTINGS, fit_streamed
    from ..signals.io import open_blocks
    from ..signals.joint_side import joint_side_blocks

    options = {k: v for k, v in dict(fit_options or {}).items() if k in STREAMED_SETTINGS}
    load = {k: v for k, v in dict(load_options or {}).items() if k != "resample"}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with open_blocks(path, **load) as src:
            result = fit_streamed(
                model,
                joint_side_blocks(model, src),  # motor-side channels through the transmission
                method=method.removeprefix("idim-"),
                progress=False,
                **options,
            )
            duration = float(src.dt * (src.n_samples - 1))
            n = int(src.n_samples)
    return result, n, duration, caught


def _float(x) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _check_paths(paths) -> list[str]:
    if isinstance(paths, (str, os.PathLike)) or not isinstance(paths, Sequence):
        raise InputError(
            f"{arg('paths')} must be a list of log files (str or Path); got "
            f"{type(paths).__name__}. Wrap one file in a list: [path]."
        )
    if not paths:
        raise InputError(f"{arg('paths')} is empty: a fleet needs at least one log file.")
    for p in paths:
        if not isinstance(p, (str, os.PathLike)):
            raise InputError(
                f"{arg('paths')} must hold file paths (str or Path); got {p!r} "
                f"({type(p).__name__})."
            )
    return [os.fspath(p) for p in paths]


def _check_model_ref(model) -> str:
    if not isinstance(model, (str, os.PathLike)):
        raise InputError(
            f"{arg('model')} must be a model name or model file path (it travels to the "
            f"workers as text and is loaded there once); got {type(model).__name__}."
        )
    return os.fspath(model)


def run_fleet(
    model,
    paths: Sequence,
    *,
    method: str = "idim-ols",
    fit_options: Mapping | None = None,
    load_options: Mapping | None = None,
    scheduler: Any = "local",
    retries: int = 2,
    against=None,
    progress: bool = True,
    model_options: Mapping | None = None,
    flags: Mapping[str, str | None] | None = None,
    scheduler_timeout: float = SCHEDULER_TIMEOUT,
) -> FleetResult:
    """Fit every log of a fleet on its own (one IDIM fit per log), in the order of ``paths``.

    Parameters
    ----------
    model : str or Path
        The fleet's model: a built-in name or a model file (URDF, TOML), loaded once per worker.
    paths : sequence of str or Path
        The logs, one per robot (or per run).
    method : {"idim-ols", "idim-wls", "idim-iv"}
    fit_options : mapping, optional
        Keywords of `physid.estimators.idim.IDIMEstimator` for every log.
    load_options : mapping, optional
        Keywords of `physid.load_recording` for every log (a ROS bag read whole is resampled
        onto its mean period, its stamps' jitter smoothed, as ``physid identify`` reads it,
        unless ``resample`` is given here: ``{"resample": False}`` keeps its stamps).
    scheduler : str or distributed.Client
        ``"local"`` (default: in-process for one or two logs, else a Dask LocalCluster with one
        single-threaded worker per CPU, at most one per log; in-process when Dask is not
        installed), ``"serial"``, ``"local:N"``, ``"tcp://HOST:PORT"`` or a Client.
    retries : int
        Dask: how many times a task that raised is retried (a fit never raises for its log;
        this covers the infrastructure, e.g. a result that could not be sent back). A task
        whose worker died is rerun by the scheduler on another worker, up to Dask's
        ``distributed.scheduler.allowed-failures`` (3) times; after that its row is failed with
        the reason (``KilledWorker``).
    against : str or Path, optional
        A reference result file (``physid identify --save``) of the same model: `FleetResult.moved`
        then flags each base parameter that moved beyond its interval since it.
    progress : bool
        Fits done and time left on stderr (`physid._progress.Progress`).
    model_options : mapping, optional
        Keywords of `physid.load_model` (``kinetic``, ...).
    flags : mapping, optional
        Python keyword → command-line flag, for the reasons of failed rows (the command line).
    scheduler_timeout : float [s]
        How long a ``tcp://`` scheduler may take to answer before `SchedulerError`.

    Returns
    -------
    FleetResult
        One row per log, in the order of ``paths``.

    Raises
    ------
    InputError
        An empty ``paths``, an unknown method, a bad ``scheduler`` or ``retries``.
    DataFileError
        ``against`` is not a physid result file, or of another model.
    SchedulerError
        A scheduler address that does not answer within ``scheduler_timeout``.

    Examples
    --------
    >>> res = run_fleet("manipulator", ["missing.csv"], scheduler="serial", progress=False)
    >>> res.rows[0]["status"], "no such file" in res.rows[0]["reason"]
    ('failed', True)
    """
    model_ref = _check_model_ref(model)
    paths = _check_paths(paths)
    if method not in FLEET_METHODS:
        raise InputError(
            f"{arg('method')} of a fleet must be one of {', '.join(FLEET_METHODS)}; got {method!r}."
        )
    retries = check_int(retries, "retries", minimum=0)
    scheduler_timeout = check_positive(scheduler_timeout, "scheduler_timeout")
    kind, address = parse_scheduler(scheduler)
    reference = None
    if against is not None:  # before any fit: a wrong reference must cost nothing
        reference = read_reference(against, _cached_model(model_ref, model_options))
    if kind == "local":
        kind, address = _local_kind(len(paths))
    task = functools.partial(
        fit_one_log,
        model_ref,
        method=method,
        fit_options=dict(fit_options or {}),
        load_options=dict(load_options or {}),
        model_options=dict(model_options or {}),
        flags=dict(flags or {}),
        workers=int(address) if kind == "dask-local" else 1,  # they share this machine's memory
    )
    start = time.perf_counter()
    backend, rows = run_tasks(task, paths, kind, address, retries, scheduler_timeout, progress)
    return FleetResult.from_rows(
        rows,
        model=model_ref,
        method=method,
        backend=backend,
        elapsed_s=time.perf_counter() - start,
        reference=reference,
        model_options=dict(model_options or {}),
    )


def run_tasks(task, paths, kind, address, retries, timeout, progress) -> tuple[str, list[dict]]:
    """Run ``task(path) -> row`` for each path on the backend ``kind``; rows in path order.

    Parameters
    ----------
    task : callable
        Picklable (a module-level function or a `functools.partial` of one).
    paths : list of str
    kind, address
        From `parse_scheduler`.
    retries : int
    timeout : float [s]
        For a scheduler address.
    progress : bool

    Returns
    -------
    tuple of (str, list of dict)
        The backend in words and the rows.
    """
    from .._progress import Progress

    with Progress(len(paths), "fleet", unit="fits", delay=2.0 if progress else math.inf) as bar:
        if kind == "local":
            kind, address = _local_kind(len(paths))
        if kind == "serial":
            rows = []
            for p in paths:
                rows.append(task(p))
                bar.advance()
            return "serial (in-process)", rows
        return _run_on_dask(task, paths, kind, address, retries, timeout, bar)


def _local_kind(n: int) -> tuple[str, Any]:
    """``scheduler="local"``: in-process for tiny fleets or without Dask, else a LocalCluster."""
    workers = min(os.cpu_count() or 1, n)
    if n <= IN_PROCESS_LIMIT or workers < 2:
        return "serial", None
    try:
        import distributed  # noqa: F401
    except ImportError:
        return "serial", None
    return "dask-local", workers


def _run_on_dask(task, paths, kind, address, retries, timeout, bar):
    with dask_client(kind, address, timeout) as (client, backend):
        return backend, map_on_dask(client, task, paths, retries, bar)


def map_on_dask(client, task, paths, retries, bar) -> list[dict]:
    """``client.map(task, paths, retries=retries, pure=False)``, gathered in path order.

    A task that still fails after its retries (its worker killed again and again: Dask's
    ``KilledWorker``) becomes a failed row naming the error; Ctrl-C cancels the remaining tasks.

    Parameters
    ----------
    client : distributed.Client
    task : callable
        ``task(path) -> row`` (picklable).
    paths : list of str
    retries : int
    bar : Progress

    Returns
    -------
    list of dict
    """
    distributed = _import_distributed()
    futures = client.map(task, paths, retries=int(retries), pure=False)
    index = {fut.key: k for k, fut in enumerate(futures)}
    rows: list[dict | None] = [None] * len(paths)
    try:
        for fut in distributed.as_completed(futures):
            k = index[fut.key]
            try:
                rows[k] = fut.result()
            except Exception as exc:  # e.g. KilledWorker after repeated deaths: record, go on
                row = _empty_row(paths[k])
                row["reason"] = f"the task was lost on the cluster ({type(exc).__name__}: {exc})"
                rows[k] = row
            bar.advance()
    except BaseException:  # Ctrl-C: free the cluster
        client.cancel(futures)
        raise
    return rows  # type: ignore[return-value]
