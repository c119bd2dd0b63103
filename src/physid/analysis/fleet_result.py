"""The table of a fleet (`FleetResult`), the moved-parameter check against a reference fit, and
the fleet's output folder (``fleet.csv``, ``fleet.parquet``, ``results/<log>.json``,
``fleet.html``).

Moved parameters: a base parameter β of one robot moved since the reference fit when

    |β − β_ref| > z · sqrt(se² + se_ref²),   z = 1.96 (`Z_MOVED`),

the two-sided 95 % test of a difference between two independent normal estimates. A parameter
present in only one of the two fits, or without a standard error in either, is reported as not
comparable (``moved`` is None), never as unchanged.
"""

from __future__ import annotations

import csv
import io
import math
import os
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._paths import _check_not_special, atomic_write
from ..errors import DataFileError, InputError, arg

__all__ = ["FleetResult", "Reference", "read_reference", "write_fleet", "Z_MOVED"]

#: z of the moved-parameter test: 1.96, two-sided 95 % for a difference of two normal estimates.
Z_MOVED = 1.96
#: Columns every row has, in this order; the base parameters follow (``NAME``, ``NAME_se``).
BASE_COLUMNS = (
    "log", "status", "reason", "n_samples", "duration", "dt", "success", "relative_error",
    "condition_number", "cutoff", "decimate", "elapsed_s",
)  # fmt: skip


@dataclass(frozen=True)
class Reference:
    """A reference fit read from a result file (``physid identify --save``).

    Parameters
    ----------
    path : str
    model : str
        The model the file names ("" when none).
    parameters : dict of str to float
        Base parameter → value.
    stderr : dict of str to float or None
        Base parameter → standard error (None: not estimated).
    """

    path: str
    model: str
    parameters: dict
    stderr: dict


def read_reference(path, model) -> Reference:
    """Read ``against=`` (a physid result file) and check it is a fit of ``model``.

    The file is parsed as JSON and checked by `physid.analysis.validation.result_file`
    (bounded size and nesting, every number finite); nothing in it is evaluated.

    Parameters
    ----------
    path : str or Path
    model : model
        The fleet's model (its base parameter names decide whether the file is of it).

    Returns
    -------
    Reference

    Raises
    ------
    DataFileError
        Not a physid result file, or one of another model (no base parameter in common).
    """
    from ..estimators.idim import base_regressor_info
    from .validation.result_file import read_result_json

    where = arg("against", repr(str(path)), cli=str(path))
    try:
        data = read_result_json(Path(path))
    except DataFileError as exc:
        raise DataFileError(f"{where}: {exc}", arguments=("against",)) from None
    params = {k: float(v) for k, v in data["parameters"].items() if isinstance(v, (int, float))}
    stderr = data.get("stderr") or {}
    names = list(base_regressor_info(model).names)
    if not set(params) & set(names):
        shown = ", ".join(list(params)[:6]) or "none"
        raise DataFileError(
            f"{where} is a result of another model: its parameters ({shown}) are none of this "
            f"model's base parameters ({', '.join(names[:6])}, ...). Give a result file written "
            "by save_result (the identify command's save option) with the same model and an "
            "idim-* method.",
            arguments=("against",),
        )
    return Reference(
        path=str(path),
        model=str(data.get("model") or ""),
        parameters=params,
        stderr={k: (float(v) if isinstance(v, (int, float)) else None) for k, v in stderr.items()},
    )


def _moved_entries(row: Mapping, names: Sequence[str], ref: Reference, z: float) -> list[dict]:
    """The moved-parameter test of one ok row against ``ref`` (see the module docstring)."""
    out = []
    for name in dict.fromkeys([*names, *ref.parameters]):
        value, se = row.get(name), row.get(name + "_se")
        r_value, r_se = ref.parameters.get(name), ref.stderr.get(name)
        entry = {
            "log": row["log"], "parameter": name, "value": value, "stderr": se,
            "reference": r_value, "reference_stderr": r_se, "change": None, "bound": None,
            "moved": None, "note": "",
        }  # fmt: skip
        if value is None or r_value is None:
            entry["note"] = "in only one of the two fits: not comparable"
        elif se is None or r_se is None:
            entry["note"] = "no standard error in one of the two fits: not comparable"
        else:
            entry["change"] = value - r_value
            entry["bound"] = z * math.sqrt(se * se + r_se * r_se)
            entry["moved"] = abs(entry["change"]) > entry["bound"]
        out.append(entry)
    return out


@dataclass(frozen=True)
class FleetResult:
    """One fit per log: the fleet's table, with the moved-parameter check.

    Parameters
    ----------
    rows : tuple of dict
        One per log, in the order given: `BASE_COLUMNS`, then ``NAME``/``NAME_se`` per base
        parameter, ``warnings``, ``result_file``, and ``moved`` (with a reference).
    results : tuple of dict or None
        Each ok log's result (``to_dict()``), for its result file.
    parameter_names : tuple of str
        The base parameters (the union over the logs, in order).
    model, method, backend : str
    elapsed_s : float [s]
    reference : Reference or None
    notes : tuple of str
    model_options : dict
    z : float
    """

    rows: tuple
    results: tuple
    parameter_names: tuple
    model: str
    method: str
    backend: str
    elapsed_s: float
    reference: Reference | None = None
    notes: tuple = ()
    model_options: dict = field(default_factory=dict)
    z: float = Z_MOVED

    @classmethod
    def from_rows(cls, rows, *, model, method, backend, elapsed_s, reference=None, **kw):
        """The result of finished tasks (`physid.analysis.fleet.fit_one_log` rows, in order).

        Returns
        -------
        FleetResult
        """
        names: list[str] = []
        results = []
        stems: set[str] = set()
        clean = []
        for r in rows:
            r = dict(r)
            results.append(r.pop("result", None))
            names.extend(n[:-3] for n in r if n.endswith("_se") and n[:-3] not in names)
            r["result_file"] = _result_name(r["log"], stems) if r["status"] == "ok" else ""
            clean.append(r)
        for r in clean:  # every row has every column
            for n in names:
                r.setdefault(n, None)
                r.setdefault(n + "_se", None)
            r.setdefault("warnings", "")
        res = cls(
            rows=tuple(clean), results=tuple(results), parameter_names=tuple(names),
            model=str(model), method=method, backend=backend, elapsed_s=float(elapsed_s),
            reference=reference, notes=_notes(clean), **kw,
        )  # fmt: skip
        if reference is not None:
            moved = {}
            for e in res.moved():
                if e["moved"]:
                    moved.setdefault(e["log"], []).append(e["parameter"])
            for r in clean:
                r["moved"] = ", ".join(moved.get(r["log"], [])) if r["status"] == "ok" else ""
        return res

    @property
    def columns(self) -> tuple:
        """The table's columns, in order."""
        params = [c for n in self.parameter_names for c in (n, n + "_se")]
        tail = ["warnings", "result_file"] + (["moved"] if self.reference is not None else [])
        return (*BASE_COLUMNS, *params, *tail)

    @property
    def success(self) -> bool:
        """Every log fitted, each with success."""
        return bool(self.rows) and all(r["status"] == "ok" and r["success"] for r in self.rows)

    def moved(self, reference=None) -> list[dict]:
        """Each ok log's base parameters against a reference fit (see the module docstring).

        Parameters
        ----------
        reference : Reference, str or Path, optional
            Default: the fleet's ``against`` reference. A path is read with `read_reference`.

        Returns
        -------
        list of dict
            ``log``, ``parameter``, ``value``, ``stderr``, ``reference``, ``reference_stderr``,
            ``change`` (β − β_ref), ``bound`` (z·sqrt(se² + se_ref²)), ``moved`` (True, False,
            or None when not comparable) and ``note``.

        Raises
        ------
        InputError
            No reference given and none in the fleet.
        """
        if reference is None:
            reference = self.reference
        if reference is None:
            raise InputError(
                f"moved() needs a {arg('reference')} result file (or run_fleet(..., against=...))."
            )
        if not isinstance(reference, Reference):
            from ..models import load_model

            model = load_model(self.model, **self.model_options)
            reference = read_reference(reference, model)
        out = []
        for r in self.rows:
            if r["status"] == "ok":
                out.extend(_moved_entries(r, self.parameter_names, reference, self.z))
        return out

    def summary(self) -> str:
        """The fleet as text: one line per log (verdict, torque error, moved parameters).

        Returns
        -------
        str
        """
        n_ok = sum(r["status"] == "ok" for r in self.rows)
        n_good = sum(r["status"] == "ok" and bool(r["success"]) for r in self.rows)
        lines = [
            f"fleet: {len(self.rows)} logs, {self.method}, model {self.model}; {n_good} fitted "
            f"with success, {n_ok - n_good} fitted without, {len(self.rows) - n_ok} failed "
            f"({self.backend}, {self.elapsed_s:.1f} s)"
        ]
        if self.reference is not None:
            lines.append(
                f"moved: |β − β_ref| > {self.z:g}·sqrt(se² + se_ref²) against {self.reference.path}"
            )
        width = max([len(Path(r["log"]).name) for r in self.rows] + [3])
        head = f"  {'log':<{width}}  {'verdict':<14} {'rel. error':>10}"
        lines.append(head + ("  moved" if self.reference is not None else "  note"))
        for r in self.rows:
            verdict = _verdict(r)
            err = r["relative_error"]
            shown = "" if err is None else f"{100 * err:.2f} %"
            tail = r.get("moved", "") if r["status"] == "ok" and self.reference else r["reason"]
            if r["status"] == "ok" and self.reference is not None and not tail:
                tail = "none"
            name = Path(r["log"]).name
            lines.append(f"  {name:<{width}}  {verdict:<14} {shown:>10}  {tail}".rstrip())
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)

    def to_csv_text(self) -> str:
        """The table as CSV text (floats with ``repr``: written exactly; None empty).

        Returns
        -------
        str
        """
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(self.columns)
        for r in self.rows:
            writer.writerow(["" if r.get(c) is None else r.get(c) for c in self.columns])
        return buf.getvalue()

    def to_csv(self, path) -> Path:
        """Write the table as CSV, atomically.

        Returns
        -------
        Path
        """
        text = self.to_csv_text()
        return atomic_write(path, lambda fh: fh.write(text))

    def to_parquet(self, path) -> Path:
        """Write the table as Parquet (needs pyarrow: ``pip install physid[parquet]``).

        Returns
        -------
        Path

        Raises
        ------
        MissingDependencyError
            pyarrow is not installed.
        """
        pq, table = _arrow_table(self)
        return atomic_write(path, lambda fh: pq.write_table(table, fh), binary=True)

    def to_pandas(self):
        """The table as a `pandas.DataFrame` (one row per log, `columns` in order).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        return pd.DataFrame([{c: r.get(c) for c in self.columns} for r in self.rows])

    def write(self, out_dir, *, page: str | None = None) -> dict:
        """Write the fleet's folder (see `write_fleet`; the page:
        `physid.report.fleet.write_fleet_report`).

        Parameters
        ----------
        out_dir : str or Path
        page : str, optional
            The fleet page's HTML.

        Returns
        -------
        dict of str to Path
        """
        return write_fleet(self, out_dir, page=page)


def _verdict(row) -> str:
    if row["status"] != "ok":
        return "failed"
    return "success" if row["success"] else "no success"


def _result_name(log: str, used: set[str]) -> str:
    stem = Path(log).stem or "log"
    name, k = stem, 1
    while name in used:
        k += 1
        name = f"{stem}-{k}"
    used.add(name)
    return f"results/{name}.json"


def _notes(rows) -> tuple:
    periods = sorted({r["dt"] for r in rows if r["status"] == "ok" and r["dt"]})
    if len(periods) > 1:
        shown = ", ".join(f"{1e3 * p:.6g} ms" for p in periods)
        return (
            f"the logs have different sampling periods ({shown}); each was fitted on its own, "
            "which is fine; one fit over all of them would need a common period.",
        )
    return ()


def _arrow_table(result: FleetResult):
    from ..errors import MissingDependencyError

    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise MissingDependencyError(
            f"Parquet needs pyarrow ({exc}); install it with `pip install physid[parquet]`, or "
            "use to_csv."
        ) from None
    arrays, fields = [], []
    for c in result.columns:
        values = [r.get(c) for r in result.rows]
        present = [v for v in values if v is not None]
        if present and all(isinstance(v, bool) for v in present):
            kind = pa.bool_()
        elif present and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in present
        ):
            kind = pa.int64() if c in ("n_samples", "decimate") else pa.float64()
        else:
            kind, values = pa.string(), [None if v is None else str(v) for v in values]
        fields.append(pa.field(c, kind))
        arrays.append(pa.array(values, type=kind))
    return pq, pa.Table.from_arrays(arrays, schema=pa.schema(fields))


class _Saved:
    """A result's dictionary, as `save_result` takes a result (it calls ``to_dict()``)."""

    model = None

    def __init__(self, data: dict):
        self._data = data

    def to_dict(self) -> dict:
        return dict(self._data)


def write_fleet(result: FleetResult, out_dir, *, page: str | None = None) -> dict:
    """Write ``fleet.csv``, ``fleet.parquet`` (with pyarrow), ``results/<log>.json`` per ok log
    and the page ``fleet.html`` (when ``page`` is given) into ``out_dir``, atomically.

    The page is rendered by the report stage (`physid.report.fleet.write_fleet_report` renders
    and writes it all): analysis comes before report and does not import it.

    The files are written into a staging folder beside ``out_dir`` and moved in at the end (the
    page last), so an interrupted write leaves ``out_dir`` as it was. The fleet's own file names
    are replaced; other files in ``out_dir`` are left alone, and a destination that is a link,
    a FIFO or a device is refused (as `physid._paths.atomic_write` refuses it).

    Parameters
    ----------
    result : FleetResult
    out_dir : str or Path
    page : str, optional
        The fleet page's HTML (`physid.report.fleet.fleet_html`).

    Returns
    -------
    dict of str to Path
        ``csv``, ``html`` (when written), ``parquet`` (when written), ``results`` (the folder); ``parquet_note``
        says why Parquet was not written.
    """
    from ..estimators.results import save_result
    from .sweep_table import _stage

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(
            f"{arg('out_dir')} {str(out)!r} exists and is not a folder; give a folder."
        )
    staging = _stage(out)
    written: dict[str, Any] = {}
    try:
        result.to_csv(staging / "fleet.csv")
        try:
            result.to_parquet(staging / "fleet.parquet")
            written["parquet"] = out / "fleet.parquet"
        except ImportError as exc:
            written["parquet_note"] = f"fleet.parquet not written: {exc}"
        (staging / "results").mkdir()
        for r, data in zip(result.rows, result.results, strict=True):
            if r["status"] == "ok" and data is not None:
                save_result(
                    _Saved(data), staging / r["result_file"], model=result.model,
                    recording=r["log"], model_options=dict(result.model_options),
                )  # fmt: skip
        if page is not None:
            atomic_write(staging / "fleet.html", lambda fh: fh.write(page))
            written["html"] = out / "fleet.html"
        _move_in(staging, out)
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
    written.update(csv=out / "fleet.csv", results=out / "results")
    return written


def _move_in(staging: Path, out: Path) -> None:
    """One rename when ``out`` is new; else file by file, each destination checked, page last."""
    if not out.exists():
        os.replace(staging, out)
        return
    names = [p.relative_to(staging) for p in staging.rglob("*") if p.is_file()]
    for name in names:  # all before anything moves: a refusal leaves the old folder whole
        _check_not_special(out / name)
    if (out / "results").exists() and not (out / "results").is_dir():
        raise InputError(f"{str(out / 'results')!r} is a file; the fleet writes a folder there.")
    (out / "results").mkdir(exist_ok=True)
    for name in sorted(names, key=lambda n: str(n) == "fleet.html"):
        os.replace(staging / name, out / name)
