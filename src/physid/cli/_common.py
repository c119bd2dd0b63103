"""Helpers shared by the verb modules: list parsing, JSON output, progress on stderr."""

from __future__ import annotations

import json
import sys
from typing import Any

from ..errors import InputError

__all__ = ["float_list", "assignments", "print_json", "progress", "add_resample_option"]


def float_list(text: str, option: str) -> list[float]:
    """Parse ``"1,2.5,3"`` into floats, naming ``option`` in the error."""
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise InputError(
            f"{option} expects comma-separated numbers such as 1,2.5,3; got {text!r}."
        ) from None


def assignments(text: str | None, option: str) -> dict[str, float]:
    """Parse ``"m1=50.1,l1=0.4"`` into a dict, naming ``option`` in the error."""
    out: dict[str, float] = {}
    if not text:
        return out
    for item in text.split(","):
        if not item.strip():
            continue
        name, sep, value = item.partition("=")
        if not sep:
            raise InputError(
                f"{option} expects NAME=VALUE pairs separated by commas; got {item!r}."
            )
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise InputError(
                f"{option}: the value of {name.strip()!r} must be a number; got {value!r}."
            ) from None
    return out


def print_json(obj: Any) -> None:
    """Print one JSON object on stdout."""
    from ..estimators.results import jsonable  # lazy: `physid --help` imports no numpy

    json.dump(jsonable(obj), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


def progress(message: str) -> None:
    """Progress goes to stderr so stdout stays machine-readable."""
    print(message, file=sys.stderr, flush=True)


def add_resample_option(parser) -> None:
    """``--resample``: accept a non-uniformly sampled recording by interpolating it."""
    parser.add_argument(
        "--resample",
        action="store_true",
        help="interpolate a non-uniformly sampled recording linearly onto a uniform grid "
        "with its mean period (default: refuse it with an error)",
    )
