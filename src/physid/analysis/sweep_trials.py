"""The trials of a sweep: the grid, each trial's seed, one trial run into a table row, and the
memory the table will need (see `physid.analysis.montecarlo` for the seeding rule)."""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._resources import MEMORY_FRACTION, check_memory, format_bytes
from .._validate import check_int
from ..errors import InputError, arg
from ..estimators.results import jsonable

__all__ = ["TrialSpec", "trial_specs", "table_memory", "BYTES_PER_TRIAL"]

#: columns of floats and short strings) and the CSV text (measured: ~2.3 kB for an MSD trial).
BYTES_PER_TRIAL = 3000


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


def _failed_rows(chunk: Sequence[TrialSpec], message: str) -> list[dict]:
    return [{**_base_row(spec), "status": "error", "message": message} for spec in chunk]


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
