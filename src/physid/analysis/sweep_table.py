"""The table of a sweep: `SweepResult` (rows, per-cell summary statistics), and its files.

`physid.analysis.montecarlo.run_sweep` returns a `SweepResult`; `write_sweep` writes its
``trials.csv`` (floats exact with ``repr``), ``trials.parquet`` (explicit schema; only with
pyarrow) and ``summary.json`` atomically; `read_table` reads a ``trials.csv`` back.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._paths import _check_not_special, _current_umask, atomic_write
from ..errors import InputError
from ..estimators.results import ResultMixin, jsonable
from .metrics import censored_median, trial_statistics

__all__ = ["SweepResult", "write_sweep", "read_table", "first_failure"]


# =========================================================================== the result
def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


@dataclass(frozen=True)
class SweepResult(ResultMixin):
    """The table of a sweep and how it was run.

    Attributes
    ----------
    grid : dict
        Axis name -> values, as given.
    trials : int
        Trials per grid point.
    seed : int
        Root seed.
    columns : tuple of str
        Column names, in table order: ``index``, the settings, ``trial``, ``seed``, ``spawn_key``,
        the trial outputs, ``status``, ``message``.
    rows : tuple of dict
        One row per trial, sorted by ``index``.
    setting_columns : tuple of str
        The columns that identify a grid cell (used to group the summary).
    censored_columns : tuple of str
        Output columns that are convergence times (NaN = never converged).
    backend : str
        What ran it (``serial``, ``local pool (2 workers)``, ``dask tcp://...``).
    elapsed_s : float
        Wall time of the sweep [s] (not part of the table, which is bit-reproducible).
    success : bool
        True when every trial has status ``"ok"``.
    message : str
    """

    grid: dict
    trials: int
    seed: int
    columns: tuple[str, ...]
    rows: tuple[dict, ...]
    setting_columns: tuple[str, ...]
    censored_columns: tuple[str, ...]
    backend: str
    elapsed_s: float
    success: bool
    message: str

    _history_fields = ("rows",)

    @property
    def parameters(self) -> dict[str, float]:
        """Counts for `summary`: trials run and trials not ``ok``."""
        n_bad = sum(r["status"] != "ok" for r in self.rows)
        return {"trials_run": float(len(self.rows)), "trials_not_ok": float(n_bad)}

    def column(self, name: str) -> np.ndarray:
        """One column as an array (float where every value is a number or None, else object)."""
        if name not in self.columns:
            raise InputError(f"no column {name!r}; the table has {list(self.columns)}.")
        values = [r.get(name) for r in self.rows]
        if all(v is None or _is_number(v) for v in values):
            return np.array([math.nan if v is None else v for v in values], dtype=float)
        return np.array(values, dtype=object)

    def select(self, **conditions) -> list[dict]:
        """Rows whose columns equal the given values, e.g. ``select(method="rls", snr_db=80)``."""
        return [r for r in self.rows if all(r.get(k) == v for k, v in conditions.items())]

    def status_counts(self) -> dict[str, int]:
        """Number of trials per status."""
        counts: dict[str, int] = {}
        for r in self.rows:
            counts[r["status"]] = counts.get(r["status"], 0) + 1
        return counts

    def summarize(self) -> list[dict]:
        """Per grid cell: the settings, the counts and, for each numeric output, its statistics.

        Returns
        -------
        list of dict
            One entry per grid cell (table order): the setting values, ``n`` (trials),
            ``n_ok`` and for each numeric output column a dict with ``n_finite``, ``mean``,
            ``median``, ``std`` (ddof = 1), ``min``, ``max`` over the finite values of the ``ok``
            trials; convergence-time columns also get ``median_censored`` (NaN counted as
            "never", `physid.analysis.metrics.censored_median`) and ``converged_fraction``.
            Every pair of output columns ``NAME_final`` / ``NAME_true`` (a final estimate and its
            truth, e.g. ``omega0_final`` / ``omega0_true``) adds ``accuracy[NAME]``: the truth
            and `physid.analysis.metrics.trial_statistics` of the final estimates over the ``ok``
            trials (``bias``, ``relative_bias``, ``std`` (the spread), ``relative_spread``,
            ``rmse``, ``relative_rmse``, ``median_relative_error``, ``n``, ``n_missing``). It is
            left out where the truth differs between the trials of a cell or is zero.
        """
        skip = {"index", "trial", "seed", "spawn_key", "status", "message", *self.setting_columns}
        outputs = [c for c in self.columns if c not in skip]
        cells: dict[tuple, list[dict]] = {}
        for r in self.rows:
            cells.setdefault(tuple(r.get(c) for c in self.setting_columns), []).append(r)
        summary = []
        for key, rows in cells.items():
            ok_rows = [r for r in rows if r["status"] == "ok"]
            entry: dict[str, Any] = dict(zip(self.setting_columns, key, strict=True))
            entry["n"] = len(rows)
            entry["n_ok"] = len(ok_rows)
            for col in outputs:
                vals = [r.get(col) for r in ok_rows]
                if not vals or not all(v is None or _is_number(v) for v in vals):
                    continue
                arr = np.array([math.nan if v is None else v for v in vals], dtype=float)
                entry[col] = _column_stats(arr, censored=col in self.censored_columns)
            accuracy = _accuracy(ok_rows, outputs)
            if accuracy:
                entry["accuracy"] = accuracy
            summary.append(entry)
        return summary

    def to_csv_text(self) -> str:
        """The table as CSV text (floats written exactly, with ``repr``; NaN as ``nan``)."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(self.columns)
        for r in self.rows:
            writer.writerow([_csv_cell(r.get(c)) for c in self.columns])
        return buf.getvalue()

    def write(self, out_dir, **kwargs) -> dict[str, Path]:
        """Write the outputs into ``out_dir`` (see `write_sweep`)."""
        return write_sweep(self, out_dir, **kwargs)

    def plot(self, **kwargs):
        """Convergence-time heat maps (`physid.report.msd.plot_convergence_maps`)."""
        from ..report.msd import plot_convergence_maps

        return plot_convergence_maps(self, **kwargs)


def _accuracy(ok_rows: Sequence[dict], outputs: Sequence[str]) -> dict[str, dict]:
    """Bias, spread and RMSE of each ``NAME_final`` column against ``NAME_true`` over a cell."""
    out = {}
    for col in outputs:
        name = col.removesuffix("_final")
        if name == col or f"{name}_true" not in outputs or not ok_rows:
            continue
        truths = {r.get(f"{name}_true") for r in ok_rows}
        if len(truths) != 1:
            continue
        truth = truths.pop()
        if not _is_number(truth) or not math.isfinite(truth) or truth == 0:
            continue
        finals = [r.get(col) for r in ok_rows]
        if not all(v is None or _is_number(v) for v in finals):
            continue
        estimates = np.array([math.nan if v is None else v for v in finals], dtype=float)
        out[name] = {"truth": float(truth), **trial_statistics(estimates, truth)}
    return out


def _column_stats(arr: np.ndarray, censored: bool) -> dict[str, Any]:
    finite = arr[np.isfinite(arr)]
    stats: dict[str, Any] = {"n_finite": int(finite.size)}
    if finite.size:
        stats.update(
            mean=float(finite.mean()),
            median=float(np.median(finite)),
            std=float(finite.std(ddof=1)) if finite.size > 1 else math.nan,
            min=float(finite.min()),
            max=float(finite.max()),
        )
    else:
        stats.update(mean=math.nan, median=math.nan, std=math.nan, min=math.nan, max=math.nan)
    if censored:
        stats["median_censored"] = censored_median(arr) if arr.size else math.nan
        stats["converged_fraction"] = float(np.isfinite(arr).mean()) if arr.size else math.nan
    return stats


def _csv_cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)  # shortest exact round-trip text
    return str(v)


def _column_order(rows: Sequence[dict], setting_columns: Sequence[str]) -> tuple[str, ...]:
    head = ["index", *setting_columns, "trial", "seed", "spawn_key"]
    outputs: dict[str, None] = {}
    for r in rows:
        for k in r:
            if k not in head and k not in ("status", "message"):
                outputs.setdefault(k, None)
    return (*head, *outputs, "status", "message")


def first_failure(rows: Sequence[Mapping[str, Any]], setting_columns: Sequence[str] = ()) -> str:
    """Where and why the first trial that is not ``ok`` failed, in one sentence.

    Parameters
    ----------
    rows : sequence of dict
        Table rows (`SweepResult.rows`).
    setting_columns : sequence of str
        The columns that name a grid cell, shown for the failed row.

    Returns
    -------
    str
        ``"the first (row 3: snr_db=25, ratio=1, trial 0) ended with status 'error': ..."``, or
        ``""`` when every row is ok.
    """
    for r in rows:
        if r.get("status") == "ok":
            continue
        where = "".join(f"{k}={r.get(k)}, " for k in setting_columns if r.get(k) is not None)
        return (
            f"the first (row {r.get('index')}: {where}trial {r.get('trial')}) ended with status "
            f"{r.get('status')!r}: {str(r.get('message') or '(no message)').rstrip('.')}"
        )
    return ""


# =========================================================================== writing
def _summary_document(result: SweepResult) -> dict:
    return jsonable(
        {
            "grid": result.grid,
            "trials": result.trials,
            "seed": result.seed,
            "n_rows": len(result.rows),
            "status_counts": result.status_counts(),
            "setting_columns": list(result.setting_columns),
            "censored_columns": list(result.censored_columns),
            "cells": result.summarize(),
            "run": {
                "backend": result.backend,
                "elapsed_s": result.elapsed_s,
                "message": result.message,
            },
        }
    )


def _arrow_column_type(pa, name: str, values: Sequence):
    """Arrow type of one table column: the seed is uint64 (SeedSequence draws all 64 bits, which
    overflow pyarrow's default int64 inference), other integer columns int64, numbers float64,
    flags bool, anything else text. An all-empty column is float64 (all null)."""
    if name == "seed":
        return pa.uint64()
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, (bool, np.bool_)) for v in present):
        return pa.bool_()
    if present and all(_is_number(v) and isinstance(v, int) for v in present):
        lo, hi = min(present), max(present)
        if lo >= -(2**63) and hi < 2**63:
            return pa.int64()
        if lo >= 0 and hi < 2**64:
            return pa.uint64()
        return pa.float64()
    if all(_is_number(v) for v in present):
        return pa.float64()
    return pa.string()


def _arrow_table(result: SweepResult):
    """The sweep table as a `pyarrow.Table` with an explicit schema (see `_arrow_column_type`)."""
    import pyarrow as pa

    fields, arrays = [], []
    for name in result.columns:
        values = [r.get(name) for r in result.rows]
        kind = _arrow_column_type(pa, name, values)
        if kind == pa.float64():
            values = [None if v is None else float(v) for v in values]
        elif kind == pa.string():
            values = [None if v is None else str(v) for v in values]
        fields.append(pa.field(name, kind))
        arrays.append(pa.array(values, type=kind))
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields))


def write_sweep(
    result: SweepResult,
    out_dir,
    *,
    stem: str = "trials",
    figures: Mapping[str, Any] | None = None,
) -> dict[str, Path]:
    """Write a sweep's table and summary (and optional figures) atomically into ``out_dir``.

    Writes ``STEM.csv``, ``STEM.parquet`` (only when pyarrow is importable), ``summary.json`` and
    ``NAME.png`` for each ``figures`` entry (name -> matplotlib Figure). The Parquet table has an
    explicit schema: ``seed`` is ``uint64`` (seeds use all 64 bits), ``index`` and ``trial``
    ``int64``, numeric outputs ``float64`` (NaN kept, missing values null), text ``string``. If
    the Parquet file cannot be written, the sweep's other files are still written and
    ``summary.json`` says why under ``outputs.parquet``. The files are written into a staging
    folder beside ``out_dir`` and moved in at the end, so an interrupted or failed write
    (Ctrl-C included) leaves ``out_dir`` as it was.

    Returns
    -------
    dict of str to Path
        ``{"csv": ..., "summary": ..., ["parquet": ...], ["figure:NAME": ...]}``.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"out_dir {str(out)!r} exists and is not a folder; give a folder path.")
    staging = _stage(out)
    try:  # interrupted (Ctrl-C) or failed: the staging folder goes, out_dir is as it was
        staged = _write_staged(result, staging, stem, figures)
        _move_in(staging, out, [p.name for p in staged.values()])
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
    return {key: out / path.name for key, path in staged.items()}


def _stage(out: Path) -> Path:
    """A fresh staging folder beside ``out`` (same file system: moving in is a rename)."""
    parent = out.absolute().parent
    parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
    staging.chmod(0o777 & ~_current_umask())  # a new out_dir gets a folder's usual mode
    return staging


def _move_in(staging: Path, out: Path, names: Sequence[str]) -> None:
    """Move the staged files into ``out``: one rename when ``out`` is new, else file by file
    (each destination checked first: no link, FIFO or device is replaced), the summary last."""
    if not out.exists():
        os.replace(staging, out)
        return
    for name in names:  # all before anything is moved: a refusal leaves the old run whole
        _check_not_special(out / name)
    for name in sorted(names, key=lambda n: n == "summary.json"):
        os.replace(staging / name, out / name)


def _write_staged(result, out: Path, stem: str, figures) -> dict[str, Path]:
    """`write_sweep`'s files, written into the (staging) folder ``out``."""
    paths: dict[str, Path] = {}
    text = result.to_csv_text()
    paths["csv"] = atomic_write(out / f"{stem}.csv", lambda fh: fh.write(text))
    outputs = {"csv": "written"}
    try:
        import pyarrow.parquet as pq
    except ImportError:
        outputs["parquet"] = "not written: pyarrow is not installed (pip install physid[parquet])"
    except Exception as exc:  # a broken pyarrow install must not cost the other outputs
        outputs["parquet"] = f"not written: importing pyarrow failed: {type(exc).__name__}: {exc}"
    else:
        try:  # the CSV is the primary output: a Parquet failure is recorded, never fatal
            table = _arrow_table(result)
            paths["parquet"] = atomic_write(
                out / f"{stem}.parquet", lambda fh: pq.write_table(table, fh), binary=True
            )
            outputs["parquet"] = "written"
        except Exception as exc:
            outputs["parquet"] = f"not written: {type(exc).__name__}: {exc}"
    doc = _summary_document(result)
    doc["outputs"] = outputs
    paths["summary"] = atomic_write(
        out / "summary.json", lambda fh: json.dump(doc, fh, indent=2, allow_nan=False)
    )
    if figures:
        from ..report.style import save_figure  # lazy: report comes after analysis

        for name, fig in figures.items():
            paths[f"figure:{name}"] = save_figure(fig, out / f"{name}.png")
    return paths


def read_table(path) -> list[dict]:
    """Read a ``trials.csv`` back: numbers as float/int, empty cells as None, text as str."""
    rows = []
    with open(path, newline="", encoding="utf-8") as fh:
        for raw in csv.DictReader(fh):
            rows.append({k: _parse_cell(v) for k, v in raw.items()})
    return rows


def _parse_cell(text: str):
    if text == "":
        return None
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text
