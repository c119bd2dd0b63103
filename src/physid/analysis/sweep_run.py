"""`run_sweep`, the driver of a sweep: check the arguments and the memory, make the trials, run
them on the chosen backend, and collect the table (see `physid.analysis.montecarlo`)."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from .._validate import check_int, check_positive
from ..errors import InputError
from .sweep_backends import SCHEDULER_TIMEOUT, _Progress, _run_trials, parse_scheduler
from .sweep_table import SweepResult, _column_order, first_failure
from .sweep_trials import _check_grid, _check_memory, trial_specs

__all__ = ["run_sweep"]


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
    >>> import numpy as np
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
    backend, rows = _run_trials(
        trial, specs, kind, address, workers, chunksize, retries, scheduler_timeout, bar
    )
    elapsed = time.perf_counter() - start
    return _sweep_result(
        rows, setting_columns, axes, trials, seed, censored_columns, backend, elapsed
    )


def _sweep_result(
    rows, setting_columns, axes, trials, seed, censored_columns, backend, elapsed
) -> SweepResult:
    """The table of a finished sweep: rows in grid order, every column in each, and the message."""
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
