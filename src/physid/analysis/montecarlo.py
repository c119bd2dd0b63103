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

This module is the engine's public face; its code is in `sweep_trials` (grid, seeds, one trial
per row, the memory check), `sweep_backends` (serial, process pool, Dask) and `sweep_run`
(`run_sweep`), and its table in `sweep_table`. The trials it runs for a model, a scenario and an
estimator are built in `physid.analysis.studies` (`model_sweep`: any linear-ODE model); the MSD
study of Oueslati et al. (2011, section 5) is `physid.analysis.msd_study` (`msd_sweep`,
`msd_trial`), whose names this module still re-exports for one release. Nothing in the engine
imports this module, so the studies can use the engine while this module imports them.
"""

from __future__ import annotations

from .._paths import atomic_write
from ..errors import MissingDependencyError as MissingDependencyError

# The msd_study names: the MSD study moved there and its names stay importable from here for one
# release (the engine modules never import the studies, so this is no cycle).
from .msd_study import MSD_NATURAL_FREQUENCY as MSD_NATURAL_FREQUENCY
from .msd_study import MSD_TIME_COLUMNS as MSD_TIME_COLUMNS
from .msd_study import _warm_up as _warm_up
from .msd_study import msd_estimator_variants as msd_estimator_variants
from .msd_study import msd_sweep as msd_sweep
from .msd_study import msd_trial as msd_trial
from .sweep_backends import DASK_HINT as DASK_HINT
from .sweep_backends import IN_PROCESS_LIMIT as IN_PROCESS_LIMIT
from .sweep_backends import SCHEDULER_TIMEOUT as SCHEDULER_TIMEOUT
from .sweep_backends import parse_scheduler
from .sweep_run import run_sweep
from .sweep_table import SweepResult, first_failure, read_table, write_sweep
from .sweep_trials import BYTES_PER_TRIAL as BYTES_PER_TRIAL
from .sweep_trials import TrialSpec, table_memory, trial_specs
from .sweep_trials import _check_memory as _check_memory

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
