"""Where the trials of a sweep run: in this process, on a local process pool, or on a Dask
cluster; the scheduler argument, the progress bar, and stopping cleanly on an interrupt."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import math
import multiprocessing
import os
import pickle
import sys
import threading
import time
from typing import Any

from ..errors import InputError, MissingDependencyError, SchedulerError, arg
from .sweep_trials import TrialSpec, _failed_rows, _run_chunk, _run_one

__all__ = ["parse_scheduler", "DASK_HINT", "IN_PROCESS_LIMIT", "SCHEDULER_TIMEOUT"]

DASK_HINT = "pip install physid[dask]"
#: Sweeps with at most this many trials run in-process under scheduler="local" (a pool costs more).
IN_PROCESS_LIMIT = 8
#: Seconds to wait for a Dask scheduler address to answer.
SCHEDULER_TIMEOUT = 30.0


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


#: The address schemes of Dask's communication backends a ``scheduler`` address may use.
_DASK_SCHEMES = ("tcp", "tls", "inproc", "ucx", "ws", "wss")


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
            scheme = scheduler.partition("://")[0].lower()
            if scheme not in _DASK_SCHEMES:
                raise InputError(
                    f"{arg('scheduler')} {scheduler!r}: a scheduler address must use one of "
                    f"the Dask schemes {', '.join(s + '://' for s in _DASK_SCHEMES)} (e.g. "
                    "'tcp://HOST:8786'); the accepted forms are 'local', 'serial', 'local:N' "
                    f"and such an address, not {scheme + '://'!r}."
                )
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


def _dask_client(distributed, address: str, timeout: float):
    """A client of the scheduler at ``address``, or `SchedulerError` after ``timeout`` s (or at
    once for an address Dask cannot parse, such as one without a port)."""
    try:
        return distributed.Client(address, timeout=f"{timeout}s")
    except ValueError as exc:  # raised by distributed's address parser
        raise SchedulerError(
            f"{arg('scheduler')} {address!r} is not a Dask scheduler address ({exc}); write it "
            "as 'tcp://HOST:PORT', e.g. 'tcp://10.0.0.2:8786'.",
            arguments=("scheduler",),
        ) from None
    except (OSError, TimeoutError) as exc:
        raise SchedulerError(
            f"could not reach the Dask scheduler at {address!r} within {timeout:g} s "
            f"({type(exc).__name__}: {exc}). Check the address and that a scheduler runs there "
            f"(`dask scheduler`), raise {arg('scheduler_timeout', 'SECONDS', cli='SECONDS')}, or "
            f"use {arg('scheduler', repr('local'), cli='local')}.",
            arguments=("scheduler",),
        ) from None


@contextlib.contextmanager
def dask_client(kind: str, address, timeout: float):
    """``(client, backend)`` for a parsed scheduler, closed (with its cluster) on exit.

    Parameters
    ----------
    kind : {"dask-client", "dask-local", "dask-address"}
        From `parse_scheduler`.
    address : distributed.Client, int or str
        The caller's client (left open), the worker count of a LocalCluster of single-threaded
        worker processes, or a scheduler address.
    timeout : float [s]
        How long a scheduler address may take to answer.

    Yields
    ------
    tuple
        The client and the backend in words.
    """
    distributed = _import_distributed()
    cluster = client = None
    try:
        if kind == "dask-client":
            client = address
            where = getattr(getattr(client, "scheduler", None), "address", "")
            backend = f"dask client {where}"
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
            client = _dask_client(distributed, address, timeout)
            backend = f"dask {address}"
        yield client, backend
    finally:
        if client is not None and kind != "dask-client":
            client.close()
        if cluster is not None:
            cluster.close()


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


def _run_trials(trial, specs, kind, address, workers, chunksize, retries, timeout, bar):
    """Run every trial on the backend ``kind`` (`parse_scheduler`); (backend in words, rows)."""
    if kind == "serial" or (kind == "local" and (workers == 1 or len(specs) <= IN_PROCESS_LIMIT)):
        return "serial (in-process)", _run_serial(trial, specs, bar)
    if kind == "local":
        return _run_local(trial, specs, workers, chunksize, retries, bar)
    return _run_on_dask(trial, specs, kind, address, chunksize, retries, timeout, bar)


def _run_local(trial, specs, workers, chunksize, retries, bar):
    n_workers = int(workers or os.cpu_count() or 1)
    if n_workers == 1:
        return "serial (in-process)", _run_serial(trial, specs, bar)
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
    return backend, _run_pool(trial, specs, n_workers, size, int(retries), bar)


def _run_on_dask(trial, specs, kind, address, chunksize, retries, timeout, bar):
    with dask_client(kind, address, timeout) as (client, backend):
        n_workers = _dask_workers(client)
        size = chunksize or _default_chunksize(len(specs), n_workers, chunks_per_worker=2)
        rows = _run_dask(client, trial, specs, size, int(retries), bar)
    return backend, rows
