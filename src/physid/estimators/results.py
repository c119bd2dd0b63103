"""Shared behaviour of estimator result objects.

Every estimator returns a frozen dataclass that mixes in `ResultMixin`: it carries the estimates,
their uncertainty where defined, the history needed for plots, ``success`` and a ``message`` that
says how to fix a failure, and offers ``summary()`` and ``to_dict()`` (JSON-ready).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["ResultMixin", "jsonable"]


def jsonable(value: Any) -> Any:
    """Convert numpy scalars/arrays, mappings and dataclasses into JSON-ready Python objects.

    Non-finite floats become ``None`` (JSON has no NaN).
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    return value


class ResultMixin:
    """``summary()`` and ``to_dict()`` for frozen result dataclasses.

    Subclasses define ``parameters`` (name -> value), ``success`` and ``message``; they may define
    ``stderr`` (name -> standard error) and list fields too large for JSON in ``_history_fields``
    (omitted from ``to_dict(history=False)``).
    """

    _history_fields: tuple[str, ...] = ()

    def to_dict(self, history: bool = False) -> dict[str, Any]:
        """JSON-ready dictionary; per-sample histories only when ``history=True``."""
        out = {}
        for f in dataclasses.fields(self):
            if not history and f.name in self._history_fields:
                continue
            out[f.name] = jsonable(getattr(self, f.name))
        return out

    def summary(self) -> str:
        """A short human-readable table of the estimates."""
        params = getattr(self, "parameters", {})
        stderr = getattr(self, "stderr", None) or {}
        lines = [f"{type(self).__name__}: {'success' if self.success else 'FAILED'}"]
        width = max((len(k) for k in params), default=4)
        for name, value in params.items():
            se = stderr.get(name)
            se_txt = f"  ± {se:.3g}" if se is not None and np.isfinite(se) else ""
            lines.append(f"  {name:<{width}} = {value:.8g}{se_txt}")
        if self.message:
            lines.append(f"  {self.message}")
        return "\n".join(lines)
