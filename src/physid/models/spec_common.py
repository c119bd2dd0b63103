"""What both kinds of TOML model file share: the TOML reader, expression-valued entries, and the
``[parameters]`` and ``[recording]`` tables."""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import ModelFileError
from ._locate import _parameter_where, _where
from .spec_types import _NAME_PATTERN, _RESERVED_PATTERN, RESERVED_NAMES, ParameterSpec

__all__ = ["read_recording_map"]


def _tomllib():
    try:
        import tomllib  # Python ≥ 3.11
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise ModelFileError(
                "reading TOML model files needs Python ≥ 3.11 (tomllib) or the 'tomli' package on "
                "Python 3.10; install it with `pip install tomli`."
            ) from None
    return tomllib


def _expr_text(value, where: str) -> str:
    if isinstance(value, bool):
        raise ModelFileError(f"{where}: expected a number or an expression string; got {value!r}.")
    if isinstance(value, (int, float)):
        return repr(float(value)) if isinstance(value, float) else str(value)
    if isinstance(value, str) and value.strip():
        return value.strip()
    raise ModelFileError(
        f'{where}: expected a number or an expression string such as "m1*l1**2/12"; got {value!r}.'
    )


def _parse_parameters(data: dict, text: str, source: str) -> tuple:
    table = data.get("parameters", {})
    if not isinstance(table, dict):
        raise ModelFileError(f"{source}: [parameters] must be a table of name = {{ value = ... }}.")
    params = []
    for pname, entry in table.items():
        where = _parameter_where(source, text, pname)
        if not _NAME_PATTERN.match(pname):
            raise ModelFileError(
                f"{where}: parameter name {pname!r} must start with a letter and hold only "
                "letters, "
                f"digits and '_'."
            )
        if pname in RESERVED_NAMES or _RESERVED_PATTERN.match(pname):
            raise ModelFileError(
                f"{where}: parameter name {pname!r} is reserved (function names, joint variables "
                f"q1, qd1, qdd1, tau1, r1, ...); rename it, e.g. {pname + '_'!r}."
            )
        if isinstance(entry, (int, float)) and not isinstance(entry, bool):
            entry = {"value": entry}
        if not isinstance(entry, dict):
            raise ModelFileError(
                f'{where}: write the parameter as {pname} = {{ value = 1.0, unit = "kg" }}; '
                f"got {entry!r}."
            )
        unknown = set(entry) - {"value", "unit", "identify", "description"}
        if unknown:
            raise ModelFileError(
                f"{where}: unknown key(s) {sorted(unknown)} for a parameter; allowed: value, unit, "
                f"identify, description."
            )
        if "value" not in entry:
            raise ModelFileError(
                f"{where}: parameter {pname!r} has no value; add value = <nominal value in SI "
                "units>."
            )
        value = entry["value"]
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise ModelFileError(
                f"{_parameter_where(source, text, pname, 'value')}: the value of {pname!r} must be "
                f"a finite number (nominal value in SI units); got {value!r}."
            )
        identify = entry.get("identify", True)
        if not isinstance(identify, bool):
            raise ModelFileError(
                f"{_parameter_where(source, text, pname, 'identify')}: identify must be true or "
                f"false; got {identify!r}."
            )
        params.append(
            ParameterSpec(
                name=pname,
                value=float(value),
                unit=str(entry.get("unit", "")),
                identify=identify,
                description=str(entry.get("description", "")),
                where=where,
            )
        )
    return tuple(params)


def _parse_recording(data: dict, text: str, source: str) -> dict:
    """The ``[recording]`` table: channel = "file variable or expression" (a channel map)."""
    table = data.get("recording", {})
    if not isinstance(table, dict):
        raise ModelFileError(
            f'{source}: [recording] must be a table of channel = "source", e.g. t = "time", '
            'q1 = "qm", tau1 = "gtau*vir".'
        )
    out = {}
    for key, value in table.items():
        if key == "rate":  # the sample rate [Hz] of files without a time column
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not (math.isfinite(value) and value > 0)
            ):
                where = _where(source, text, "recording.rate", key, table="recording")
                raise ModelFileError(
                    f"{where}: recording.rate is the sample rate in Hz of files without a time "
                    f"column, a number > 0 (e.g. rate = 5000); got {value!r}."
                )
            out["rate"] = repr(float(value))
            continue
        if not isinstance(value, str) or not value.strip():
            where = _where(source, text, f"recording.{key}", key, table="recording")
            raise ModelFileError(
                f"{where}: recording.{key} must be a string naming a variable of the file or an "
                f'expression over them, e.g. {key} = "gtau*vir"; got {value!r}.'
            )
        out[str(key)] = value.strip()
    return out


def read_recording_map(path) -> dict:
    """The ``[recording]`` channel map of a model file (empty if it has none).

    Parameters
    ----------
    path : str or Path
        A ``.toml`` model file (chain or linear ODE).

    Returns
    -------
    dict
        channel → source text, for `physid.load_recording(path, channels=...)`.

    Raises
    ------
    ModelFileError
        The file cannot be read, is not TOML, or the table is malformed.
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"cannot read model file {str(path)!r}: {exc}.") from None
    tomllib = _tomllib()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelFileError(f"{path}: not valid TOML: {exc}.") from None
    return _parse_recording(data, text, str(path))
