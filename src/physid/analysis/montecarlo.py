"""Monte-Carlo sweeps: a grid of settings × seeds, run locally or on a Dask cluster.

A sweep runs one *trial function* for every point of a grid (the Cartesian product of named axes,
e.g. SNR × frequency ratio × estimator settings) and every trial number ``0 .. trials-1``. It
returns a tidy table: one row per trial holding the settings, the seed, the trial's outputs (its
estimates and metrics), a ``status`` (``"ok"``, a status the trial reported itself, or ``"error"``
when it raised) and a ``message``.

Reproducibility
    Every trial's seed comes from one root seed through `numpy.random.SeedSequence`: the trial at
    grid index ``(i_1, ..., i_k)`` and trial number ``j`` uses ``SeedSequence(root,
    spawn_key=(i_1, ..., i_k, j))``, which is exactly the child reached by the nested calls
    ``SeedSequence(root).spawn(n_1)[i_1]. ... .spawn(trials)[j]``. The seed depends only on the grid
    position, never on which worker ran the trial or when, so the same root seed gives the same bits
    with every backend. Axes named in ``shared_seed_axes`` are left out of the key: trials that
    differ only along them see the same random data (the MSD sweep uses this so that the algebraic
    and the recursive estimator are compared on the very same noisy records).

Backends (``scheduler=``)
    ``"local"`` (default): a process pool of ``workers`` processes (default: every CPU) fed with
    chunks of trials; tiny sweeps (or ``workers=1``) run in this process. ``"serial"`` always runs
    in this process. ``"local:N"`` starts a Dask ``LocalCluster`` with N single-threaded worker
    processes for the duration of the sweep; ``"tcp://HOST:PORT"`` connects to a running Dask
    scheduler; a ``distributed.Client`` is used as is. Dask is optional (``pip install
    physid[dask]``) and imported only for those schedulers. Dask reruns the trials of a worker that
    dies (and retries a chunk that raised an unexpected error ``retries`` times); the local pool
    restarts itself after a crashed worker the same number of times.

Failures
    A trial that raises is recorded with ``status="error"`` and the exception in ``message``; the
    sweep goes on. A trial may also return its own ``status`` and ``message`` (e.g. an estimator
    that ran but did not succeed).

Outputs (`write_sweep`)
    ``trials.csv`` (and ``trials.parquet`` when pyarrow is installed), ``summary.json`` (grouped
    count, mean, median, spread per grid cell; bias, spread and RMSE of each final estimate
    against its truth; run information; which files were written). Every file is written to a
    temporary file in the target folder and renamed into place, so an interrupted sweep never leaves
    a half-written file.

Interrupts and resources
    Ctrl-C (SIGINT) or SIGTERM stops the sweep: queued work is cancelled and the local pool's
    workers are killed before the exception propagates (the CLI exits 130 or 143). Before any
    trial is generated, the memory the table will need is estimated and a request beyond what
    the machine has is refused with the numbers. A Dask scheduler address that cannot be reached
    within ``scheduler_timeout`` seconds raises `physid.errors.SchedulerError`.

This module is the generic engine. The trials it runs for a model, a scenario and an estimator
are built in `physid.analysis.studies` (`model_sweep`: any linear-ODE model); the MSD study of
Oueslati et al. (2011, section 5) is `physid.analysis.msd_study` (`msd_sweep`, `msd_trial`).
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import json
import math
import multiprocessing
import os
import pickle
import sys
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._paths import atomic_write
from .._resources import MEMORY_FRACTION, check_memory, format_bytes
from .._validate import check_int, check_positive
from ..errors import InputError, MissingDependencyError, SchedulerError, arg
from ..estimators.results import jsonable
from .sweep_table import SweepResult, _column_order, first_failure, read_table, write_sweep

__all__ = [
    "TrialSpec",
    "SweepResult",
    "trial_specs",
    "run_sweep",
    "write_sweep",
    "read_table",
    "atomic_write",
    "parse_scheduler",
    "table_memory",
    "first_failure",
]

DASK_HINT = "pip install physid[dask]"
#: Sweeps with at most this many trials run in-process under scheduler="local" (a pool costs more).
IN_PROCESS_LIMIT = 8
#: Bytes one trial costs in memory while a sweep runs: its TrialSpec, its row dict (about 20
#: columns of floats and short strings) and the CSV text (measured: ~2.3 kB for an MSD trial).
BYTES_PER_TRIAL = 3000
#: Seconds to wait for a Dask scheduler address to answer.
SCHEDULER_TIMEOUT = 30.0
#: Moved to physid.analysis.msd_study; still importable from here (see `__getattr__`).
_MOVED = {
    "msd_trial",
    "msd_sweep",
    "msd_estimator_variants",
    "MSD_TIME_COLUMNS",
    "MSD_NATURAL_FREQUENCY",
    "_warm_up",
}


def __getattr__(name):
    # The MSD study moved to physid.analysis.msd_study (issue 12 item 8); the old names keep
    # working for one release. Lazy, so the engine never imports the study (no cycle).
    if name in _MOVED:
        from . import msd_study

        return getattr(msd_study, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# =========================================================================== grid and seeds
@dataclass(frozen=True)
class TrialSpec:
    """One trial of a sweep: where it sits in the grid and the seed it must use.

    Attributes
    ----------
    index : int
        Row number in the table (grid points in C order, trial number innermost).
    grid_index : tuple of int
        Index along each axis.
    trial : int
        Trial number within its grid cell.
    settings : dict
        Axis name -> value; mapping-valued axis values are merged in (their keys become settings).
    spawn_key : tuple of int
        Key of the trial's `numpy.random.SeedSequence` under the root seed.
    seed : int
        A 64-bit integer drawn from that SeedSequence; the trial function seeds its generator with
        (``np.random.default_rng(seed)``), so a row of the table is reproducible on its own.
    """

    index: int
    grid_index: tuple[int, ...]
    trial: int
    settings: dict
    spawn_key: tuple[int, ...]
    seed: int


def _check_grid(grid: Mapping[str, Sequence]) -> dict[str, tuple]:
    if not isinstance(grid, Mapping) or not grid:
        raise InputError(
            f"grid must be a non-empty mapping axis name -> list of values; got {grid!r}."
        )
    out = {}
    for name, values in grid.items():
        if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
            raise InputError(
                f"grid axis {name!r} must be a list of values; got {values!r}. "
                "Wrap a single value: "
                f"[{values!r}]."
            )
        values = tuple(values)
        if not values:
            raise InputError(f"grid axis {name!r} is empty; give it at least one value.")
        out[str(name)] = values
    return out


def _settings_of(axes: Mapping[str, tuple], idx: Sequence[int]) -> dict:
    settings: dict[str, Any] = {}
    for (name, values), i in zip(axes.items(), idx, strict=True):
        value = values[i]
        if isinstance(value, Mapping):
            settings.update(value)
        else:
            settings[name] = value
    return settings


def _seed_for(root: int, key: tuple[int, ...]) -> int:
    # SeedSequence(root, spawn_key=key) is the child nested .spawn() calls reach (see module doc)
    return int(np.random.SeedSequence(root, spawn_key=key).generate_state(1, np.uint64)[0])


def _check_seed(seed) -> int:
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be a non-negative integer; got {seed!r}.")
    return int(seed)


def trial_specs(
    grid: Mapping[str, Sequence],
    trials: int,
    seed: int = 0,
    *,
    shared_seed_axes: Sequence[str] = (),
) -> list[TrialSpec]:
    """Every trial of a grid with its seed, in table order.

    Parameters
    ----------
    grid : mapping of str to sequence
        Axis name -> values. A value may itself be a mapping (e.g. one estimator configuration
        ``{"method": "rls", "forgetting": 0.99}``); its keys are merged into the settings.
    trials : int
        Trials (seeds) per grid point, >= 1.
    seed : int
        Root seed (non-negative integer).
    shared_seed_axes : sequence of str
        Axes whose index is left out of the seed's spawn key (trials that differ only along them
        share their random data).

    Returns
    -------
    list of TrialSpec
        ``prod(len(axis)) * trials`` specs; index = row number.

    Examples
    --------
    >>> specs = trial_specs({"snr_db": [25, 80], "ratio": [1, 10]}, trials=3, seed=7)
    >>> len(specs), specs[5].settings, specs[5].trial, specs[5].spawn_key
    (12, {'snr_db': 25, 'ratio': 10}, 2, (0, 1, 2))
    """
    axes = _check_grid(grid)
    trials = check_int(trials, "trials", minimum=1)
    root = _check_seed(seed)
    unknown = set(shared_seed_axes) - set(axes)
    if unknown:
        raise InputError(
            f"shared_seed_axes names unknown axes {sorted(unknown)}; "
            f"the grid's axes are {list(axes)}."
        )
    keep = [k for k, name in enumerate(axes) if name not in set(shared_seed_axes)]
    shape = [len(v) for v in axes.values()]
    specs = []
    for index, (*idx, j) in enumerate(itertools.product(*map(range, shape), range(int(trials)))):
        key = tuple(idx[k] for k in keep) + (j,)
        specs.append(
            TrialSpec(index, tuple(idx), j, _settings_of(axes, idx), key, _seed_for(root, key))
        )
    return specs


# =========================================================================== running trials
def _run_one(trial: Callable, spec: TrialSpec) -> dict:
    """Run one trial; never raises (an exception becomes status='error')."""
    row = _base_row(spec)
    try:
        out = trial(dict(spec.settings), spec.seed)
        if out is None:
            out = {}
        if not isinstance(out, Mapping):
            raise TypeError(
                f"the trial function must return a mapping name -> value; got {type(out).__name__}"
            )
        out = dict(out)
        status = str(out.pop("status", "ok"))
        message = str(out.pop("message", ""))
        for name, value in out.items():
            row[str(name)] = _scalar(value, name)
    except Exception as exc:  # recorded, never fatal
        status, message = "error", f"{type(exc).__name__}: {exc}"
    row["status"] = status
    row["message"] = message
    return row


def _setting_cell(value):
    if value is None or isinstance(value, (str, bool, int, float)):
        return value
    try:
        return _scalar(value, "setting")
    except TypeError:  # a structured setting (e.g. estimator options): JSON text in the table
        return json.dumps(jsonable(value), sort_keys=True)


def _base_row(spec: TrialSpec) -> dict[str, Any]:
    return {
        "index": spec.index,
        **{k: _setting_cell(v) for k, v in spec.settings.items()},
        "trial": spec.trial,
        "seed": spec.seed,
        "spawn_key": "-".join(map(str, spec.spawn_key)),
    }


def _scalar(value, name):
    if value is None or isinstance(value, (str, bool)):
        return value
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return _scalar(value.item(), name)
    raise TypeError(
        f"trial output {name!r} must be a scalar (number, str, bool or None) to fit in a table; "
        "got "
        f"{type(value).__name__}"
    )


def _run_chunk(specs: Sequence[TrialSpec], trial: Callable) -> list[dict]:
    """Run a chunk of trials in order (the unit of work of every backend)."""
    return [_run_one(trial, spec) for spec in specs]


class _Progress:
    """A one-line text progress bar on stderr (no dependency)."""

    def __init__(self, total: int, label: str, enabled: bool, stream=None):
        self.total = max(int(total), 1)
        self.done = 0
        self.label = label
        self.enabled = enabled
        self.stream = stream if stream is not None else sys.stderr
        self.start = time.perf_counter()
        self._last = -1.0
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._printed_decile = -1

    def advance(self, n: int) -> None:
        self.done += n
        if not self.enabled:
            return
        now = time.perf_counter()
        finished = self.done >= self.total
        if self._tty:
            if finished or now - self._last > 0.1:
                self._last = now
                self.stream.write("\r" + self._line(now))
                if finished:
                    self.stream.write("\n")
                self.stream.flush()
        else:  # a log file: one line per 10 %
            decile = int(10 * self.done / self.total)
            if decile > self._printed_decile:
                self._printed_decile = decile
                self.stream.write(self._line(now) + "\n")
                self.stream.flush()

    def _line(self, now: float) -> str:
        width = 30
        filled = int(width * self.done / self.total)
        bar = "#" * filled + "." * (width - filled)
        return f"{self.label} [{bar}] {self.done}/{self.total} trials {now - self.start:6.1f} s"


def _chunks(specs: list[TrialSpec], chunksize: int) -> list[list[TrialSpec]]:
    return [specs[i : i + chunksize] for i in range(0, len(specs), chunksize)]


def _default_chunksize(n: int, workers: int, chunks_per_worker: int = 4) -> int:
    """Trials per task: ``chunks_per_worker`` tasks per worker balance the load, and fewer,
    larger tasks pay less scheduling overhead. The local pool uses 4; Dask, whose tasks cost a
    scheduler round trip and serialisation each, uses 2 (measured on 2 cores, 100 MSD records:
    1.97x with 1 task per worker, 1.79x with 4, 1.5x with 10)."""
    return max(1, math.ceil(n / (chunks_per_worker * max(workers, 1))))


def parse_scheduler(scheduler) -> tuple[str, Any]:
    """Classify a ``scheduler`` argument as ``(kind, argument)``.

    ``kind`` is one of ``"serial"``, ``"local"``, ``"dask-local"``, ``"dask-address"``,
    ``"dask-client"``.

    Examples
    --------
    >>> parse_scheduler("local:3"), parse_scheduler("tcp://10.0.0.2:8786")
    (('dask-local', 3), ('dask-address', 'tcp://10.0.0.2:8786'))
    """
    if scheduler is None or scheduler == "local":
        return "local", None
    if scheduler == "serial":
        return "serial", None
    if isinstance(scheduler, str):
        if scheduler.startswith("local:"):
            n = scheduler.partition(":")[2]
            if not n.isdigit() or int(n) < 1:
                raise InputError(
                    f"scheduler {scheduler!r}: 'local:N' needs a worker count N >= 1, "
                    "e.g. 'local:2'."
                )
            return "dask-local", int(n)
        if "://" in scheduler:
            return "dask-address", scheduler
        raise InputError(
            "scheduler must be 'local', 'serial', 'local:N' (a Dask LocalCluster with N workers) "
            "or "
            f"a Dask scheduler address such as 'tcp://HOST:8786'; got {scheduler!r}."
        )
    if hasattr(scheduler, "map") and hasattr(scheduler, "gather"):
        return "dask-client", scheduler
    raise InputError(
        f"scheduler must be a string ('local', 'local:N', 'tcp://HOST:PORT') or a "
        f"distributed.Client; got {type(scheduler).__name__}."
    )


def _import_distributed():
    try:
        import distributed
    except ImportError as exc:
        raise MissingDependencyError(
            f"Dask schedulers need the optional 'dask' extra ({exc}); install it with "
            f"`{DASK_HINT}`, or use scheduler='local'."
        ) from None
    return distributed


def _run_serial(trial, specs, bar):
    rows = []
    for spec in specs:
        rows.append(_run_one(trial, spec))
        bar.advance(1)
    return rows


def _pool_context(trial):
    # fork is cheapest (workers inherit this process's imports and caches), but forking a process
    # that runs other threads (a Dask client, a GUI) can deadlock; then use a fork server.
    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and threading.active_count() == 1:
        return multiprocessing.get_context("fork")
    if "forkserver" in methods:
        ctx = multiprocessing.get_context("forkserver")
        # the fork server imports these once; each pool worker then starts as a cheap fork of it
        preload = ["numpy", "physid.analysis.montecarlo", *getattr(trial, "preload_modules", ())]
        module = getattr(trial, "__module__", None)
        if module and module != "__main__" and module not in preload:
            preload.append(module)
        ctx.set_forkserver_preload(preload)
        return ctx
    return multiprocessing.get_context("spawn")


_BLAS_THREAD_SETTERS = (
    "openblas_set_num_threads",
    "openblas_set_num_threads64_",
    "scipy_openblas_set_num_threads",
    "scipy_openblas_set_num_threads64_",
    "MKL_Set_Num_Threads",
)


def _single_threaded_blas() -> None:
    """Pool-worker initializer: one BLAS thread per worker process.

    Trials use tiny matrices; with several worker processes a multi-threaded BLAS only adds
    contention (measured: 3.5x slower per MSD trial on a busy 2-core machine). The environment
    variables (OPENBLAS_NUM_THREADS=1 ...) act only before numpy is imported, and forked workers
    inherit an initialised BLAS, so the libraries already loaded are told directly, the way
    threadpoolctl does it. Linux only (reads /proc/self/maps); elsewhere this does nothing. Dask's
    nanny already starts its workers with these variables set to 1.
    """
    import ctypes
    import signal

    # a worker that inherited the CLI's SIGTERM handler would raise inside the pool's machinery;
    # the parent kills its workers itself when it is terminated
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[name] = "1"  # for libraries imported later in this worker
    try:
        with open("/proc/self/maps", encoding="utf-8") as fh:
            libs = {line.split()[-1] for line in fh if "blas" in line.lower() or "mkl" in line}
    except OSError:
        return
    for path in libs:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for symbol in _BLAS_THREAD_SETTERS:
            setter = getattr(lib, symbol, None)
            if setter is not None:
                setter(1)


def _failed_rows(chunk: Sequence[TrialSpec], message: str) -> list[dict]:
    return [{**_base_row(spec), "status": "error", "message": message} for spec in chunk]


def _run_pool(trial, specs, workers, chunksize, retries, bar):
    pending = _chunks(specs, chunksize)
    rows: list[dict] = []
    attempts = 0
    while pending:
        broken: list[list[TrialSpec]] = []
        pool = cf.ProcessPoolExecutor(
            max_workers=workers, mp_context=_pool_context(trial), initializer=_single_threaded_blas
        )
        try:
            futures = {pool.submit(_run_chunk, chunk, trial): chunk for chunk in pending}
            for fut in cf.as_completed(futures):
                try:
                    chunk_rows = fut.result()
                except cf.process.BrokenProcessPool:  # a worker died: rerun its chunk
                    broken.append(futures[fut])
                    continue
                except Exception as exc:  # infrastructure (e.g. unpicklable output): record it
                    chunk_rows = _failed_rows(futures[fut], f"{type(exc).__name__}: {exc}")
                rows.extend(chunk_rows)
                bar.advance(len(chunk_rows))
        except BaseException:  # Ctrl-C or SIGTERM: stop now, leave no worker behind
            _kill_pool(pool)
            raise
        pool.shutdown(wait=True)
        pending = broken
        if pending:
            attempts += 1
            if attempts > retries:
                lost = [s for chunk in pending for s in chunk]
                rows.extend(_failed_rows(lost, f"worker process died {attempts} times running it"))
                bar.advance(len(lost))
                pending = []
    return rows


def _kill_pool(pool: cf.ProcessPoolExecutor) -> None:
    """Cancel the queued chunks and kill the pool's worker processes.

    ``shutdown(wait=False)`` alone lets each worker finish its current chunk, and a process that
    was sent SIGTERM exits before they do, leaving them blocked on their queue forever.
    """
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for proc in processes:
        try:
            proc.kill()
        except (OSError, ValueError):  # already gone
            pass
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        try:
            proc.join(timeout=5)
        except (OSError, ValueError, AssertionError):
            pass


def table_memory(grid: Mapping[str, Sequence], trials: int) -> tuple[int, int]:
    """Number of trials of a sweep and the memory [bytes] its table needs while it runs.

    Parameters
    ----------
    grid : mapping of str to sequence
        Axis name → values (see `trial_specs`).
    trials : int
        Trials per grid point.

    Returns
    -------
    (n_trials, bytes) : tuple of int
        ``prod(len(axis)) · trials`` and that times `BYTES_PER_TRIAL`.

    Examples
    --------
    >>> table_memory({"snr_db": [25, 50], "ratio": [1, 5, 10]}, 100)
    (600, 1800000)
    """
    axes = _check_grid(grid)
    trials = check_int(trials, "trials", minimum=1)
    n = math.prod(len(v) for v in axes.values()) * trials
    return n, n * BYTES_PER_TRIAL


def _check_memory(grid, trials) -> None:
    n, need = table_memory(grid, trials)
    cells = n // trials

    def message(need: float, available: int) -> str:
        return (
            f"a sweep of {n:,} trials ({cells} grid point(s) × {arg('trials')} = {trials:,}) "
            f"needs about {format_bytes(need)} of memory for its table ({BYTES_PER_TRIAL} B per "
            f"trial), but this machine has {format_bytes(available)} available (a sweep may use "
            f"{MEMORY_FRACTION:.0%}). Use fewer {arg('trials')} or grid points (at most about "
            f"{int(MEMORY_FRACTION * available / BYTES_PER_TRIAL / cells):,} trials per point "
            "here), or split the study into several sweeps with different seeds."
        )

    check_memory(need, what="the sweep", fix=f"use fewer {arg('trials')}", message=message)


def _dask_client(distributed, address: str, timeout: float):
    """A client of the scheduler at ``address``, or `SchedulerError` after ``timeout`` s."""
    try:
        return distributed.Client(address, timeout=f"{timeout}s")
    except (OSError, TimeoutError) as exc:
        raise SchedulerError(
            f"could not reach the Dask scheduler at {address!r} within {timeout:g} s "
            f"({type(exc).__name__}: {exc}). Check the address and that a scheduler runs there "
            f"(`dask scheduler`), raise {arg('scheduler_timeout', 'SECONDS', cli='SECONDS')}, or "
            f"use {arg('scheduler', repr('local'), cli='local')}.",
            arguments=("scheduler",),
        ) from None


def _run_dask(client, trial, specs, chunksize, retries, bar):
    distributed = _import_distributed()
    chunks = _chunks(specs, chunksize)
    futures = client.map(_run_chunk, chunks, trial=trial, retries=retries, pure=False)
    chunk_of = {fut.key: chunk for fut, chunk in zip(futures, chunks, strict=True)}
    rows: list[dict] = []
    try:
        for fut in distributed.as_completed(futures):
            try:
                chunk_rows = fut.result()
            except Exception as exc:  # e.g. KilledWorker after repeated deaths: record, go on
                chunk_rows = _failed_rows(chunk_of[fut.key], f"{type(exc).__name__}: {exc}")
            rows.extend(chunk_rows)
            bar.advance(len(chunk_rows))
    except BaseException:  # Ctrl-C: free the cluster
        client.cancel(futures)
        raise
    return rows


def _dask_workers(client) -> int:
    try:
        return max(1, sum(client.nthreads().values()))
    except Exception:  # a client that cannot say: assume one worker
        return 1


# =========================================================================== the driver
def run_sweep(
    trial: Callable[[dict, int], Mapping[str, Any]],
    grid: Mapping[str, Sequence],
    *,
    trials: int = 1,
    seed: int = 0,
    scheduler: Any = "local",
    workers: int | None = None,
    chunksize: int | None = None,
    retries: int = 2,
    shared_seed_axes: Sequence[str] = (),
    censored_columns: Sequence[str] = (),
    progress: bool = True,
    label: str = "sweep",
    scheduler_timeout: float = SCHEDULER_TIMEOUT,
) -> SweepResult:
    """Run ``trial`` on every grid point and trial number; return the tidy table.

    Parameters
    ----------
    trial : callable
        ``trial(settings: dict, seed: int) -> mapping`` of scalar outputs (numbers, str, bool,
        None); may include ``status`` and ``message``. Must be picklable (a module-level function)
        for the process pool and Dask. It should seed all its randomness from ``seed``.
    grid : mapping of str to sequence
        Axis name -> values (see `trial_specs`).
    trials : int
        Trials per grid point.
    seed : int
        Root seed.
    scheduler : str or distributed.Client
        ``"local"`` (process pool; in-process for tiny sweeps), ``"serial"``, ``"local:N"`` (Dask
        LocalCluster with N worker processes, one thread each), ``"tcp://HOST:PORT"`` (a running
        Dask scheduler) or a ``distributed.Client``.
    workers : int, optional
        Processes of the local pool; default: every CPU (``os.cpu_count()``).
    chunksize : int, optional
        Trials per task; default about four tasks per worker.
    retries : int
        Dask: how many times a task that raised is retried (a task whose worker died is rerun by the
        scheduler anyway). Local pool: how many times the pool is restarted after a worker crash.
    shared_seed_axes : sequence of str
        Axes left out of the seed key (see `trial_specs`).
    censored_columns : sequence of str
        Output columns holding convergence times (NaN = never); used by `SweepResult.summarize`.
    progress : bool
        Show a progress bar on stderr.
    label : str
        Text in front of the progress bar.
    scheduler_timeout : float [s]
        How long to wait for a ``"tcp://..."`` scheduler to answer (default 30 s) before raising
        `physid.errors.SchedulerError`.

    Returns
    -------
    SweepResult
        The table; ``success`` is False when any trial is not ``ok``, and ``message`` names the
        first failure when every trial failed.

    Raises
    ------
    InputError
        Bad settings, or a table larger than half the available memory (the message gives the
        numbers).
    SchedulerError
        A scheduler address that does not answer within ``scheduler_timeout``.

    Examples
    --------
    >>> def noisy_mean(settings, seed):
    ...     x = np.random.default_rng(seed).normal(settings["mu"], 1.0, 100)
    ...     return {"mean": x.mean()}
    >>> res = run_sweep(noisy_mean, {"mu": [0.0, 5.0]}, trials=3, seed=1, scheduler="serial",
    ...                 progress=False)
    >>> len(res.rows), res.success, res.summarize()[1]["mean"]["n_finite"]
    (6, True, 3)
    """
    if not callable(trial):
        raise InputError(f"trial must be a callable trial(settings, seed) -> dict; got {trial!r}.")
    retries = check_int(retries, "retries", minimum=0)
    workers = check_int(workers, "workers", minimum=1, allow_none=True, fix="None uses every CPU.")
    chunksize = check_int(chunksize, "chunksize", minimum=1, allow_none=True)
    scheduler_timeout = check_positive(scheduler_timeout, "scheduler_timeout")
    kind, address = parse_scheduler(scheduler)
    if workers is not None and kind != "local":
        raise InputError(
            f"workers={workers} applies to scheduler='local' only; with {scheduler!r} the "
            "worker count is the scheduler's (use 'local:N' for a Dask LocalCluster of N workers)."
        )
    _check_memory(grid, trials)  # before anything of that size is allocated
    specs = trial_specs(grid, trials, seed, shared_seed_axes=shared_seed_axes)
    axes = _check_grid(grid)
    setting_columns: list[str] = []
    for spec in specs:
        for k in spec.settings:
            if k not in setting_columns:
                setting_columns.append(k)
    bar = _Progress(len(specs), label, progress)
    start = time.perf_counter()
    if kind == "serial" or (kind == "local" and (workers == 1 or len(specs) <= IN_PROCESS_LIMIT)):
        backend = "serial (in-process)"
        rows = _run_serial(trial, specs, bar)
    elif kind == "local":
        n_workers = int(workers or os.cpu_count() or 1)
        if n_workers == 1:
            backend = "serial (in-process)"
            rows = _run_serial(trial, specs, bar)
        else:
            try:
                pickle.dumps(trial)
            except Exception as exc:
                raise InputError(
                    f"the trial function {trial!r} cannot be sent to worker processes ({exc}); "
                    "define it at module level (not a lambda or a nested function), or use "
                    "scheduler='serial'."
                ) from None
            size = chunksize or _default_chunksize(len(specs), n_workers)
            backend = f"local process pool ({n_workers} workers, {size} trials per task)"
            rows = _run_pool(trial, specs, n_workers, size, int(retries), bar)
    else:
        distributed = _import_distributed()
        cluster = None
        client = None
        try:
            if kind == "dask-client":
                client = address
                backend = (
                    f"dask client {getattr(client, 'scheduler', None) and client.scheduler.address}"
                )
            elif kind == "dask-local":
                import logging

                cluster = distributed.LocalCluster(
                    n_workers=address,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    silence_logs=logging.ERROR,
                )
                client = distributed.Client(cluster)
                backend = f"dask LocalCluster ({address} worker processes)"
            else:
                client = _dask_client(distributed, address, scheduler_timeout)
                backend = f"dask {address}"
            n_workers = _dask_workers(client)
            size = chunksize or _default_chunksize(len(specs), n_workers, chunks_per_worker=2)
            rows = _run_dask(client, trial, specs, size, int(retries), bar)
        finally:
            if client is not None and kind != "dask-client":
                client.close()
            if cluster is not None:
                cluster.close()
    elapsed = time.perf_counter() - start
    rows.sort(key=lambda r: r["index"])
    for r in rows:  # rows of trials that failed early lack some outputs: fill with None
        for c in setting_columns:
            r.setdefault(c, None)
    columns = _column_order(rows, setting_columns)
    full_rows = tuple({c: r.get(c) for c in columns} for r in rows)
    n_bad = sum(r["status"] != "ok" for r in full_rows)
    message = f"{len(full_rows)} trials on {backend} in {elapsed:.1f} s" + (
        f"; {n_bad} not ok (see the status and message columns)" if n_bad else ""
    )
    if full_rows and n_bad == len(full_rows):
        message = (
            f"every trial failed ({n_bad} of {n_bad}); {first_failure(full_rows, setting_columns)}"
        )
    return SweepResult(
        grid={k: list(v) for k, v in axes.items()},
        trials=int(trials),
        seed=int(seed),
        columns=columns,
        rows=full_rows,
        setting_columns=tuple(setting_columns),
        censored_columns=tuple(censored_columns),
        backend=backend,
        elapsed_s=float(elapsed),
        success=n_bad == 0,
        message=message,
    )
