"""Errors raised by physid.

Every error says what was received, what was expected and how to fix it. Each class also derives
from the builtin a caller would naturally catch (``ValueError`` or ``TypeError``), so code written
against plain Python exceptions keeps working.
"""

from __future__ import annotations

__all__ = [
    "PhysidError",
    "InputError",
    "ShapeError",
    "SamplingError",
    "DataFileError",
    "ModelFileError",
    "ExpressionError",
    "IdentifiabilityError",
    "EstimationError",
    "SimulationError",
    "MissingDependencyError",
]


class PhysidError(Exception):
    """Base class of every error physid raises on purpose."""


class InputError(PhysidError, ValueError):
    """An argument has a value outside its allowed range or set."""


class ShapeError(PhysidError, ValueError):
    """An array has the wrong shape, or arrays that must agree in length do not."""


class SamplingError(PhysidError, ValueError):
    """A time vector is not strictly increasing, not uniform, or too short for the request."""


class DataFileError(PhysidError, ValueError):
    """A recording file cannot be read: missing columns, bad cells, unsupported format."""


class ModelFileError(PhysidError, ValueError):
    """A model file (TOML) is malformed: unknown symbol, bad transform, missing value."""


class ExpressionError(PhysidError, ValueError):
    """User-written arithmetic (a model expression, a channel map) is refused by the parser.

    Raised by `physid.expressions`. Besides the message, ``reason`` says why in one word
    (``"syntax"``, ``"forbidden"``, ``"too_large"``, ``"unknown_name"``, ``"unknown_function"``,
    ``"not_callable"``, ``"arguments"``, ``"not_finite"``, ``"invalid"``, ``"type"``,
    ``"argument"``), ``names`` holds the offending names, ``text`` the expression and ``source``
    where it was written, so that callers can reword the message for their context.
    """

    def __init__(self, message: str, *, reason: str = "invalid", names=(), text="", source=""):
        super().__init__(message)
        self.reason = reason
        self.names = tuple(names)
        self.text = text
        self.source = source

    def __reduce__(self):  # keep the keywords through pickling (process pools)
        return (
            _rebuild_expression_error,
            (str(self), self.reason, self.names, self.text, self.source),
        )


def _rebuild_expression_error(message, reason, names, text, source):
    return ExpressionError(message, reason=reason, names=names, text=text, source=source)


class IdentifiabilityError(PhysidError, ValueError):
    """The data or the model cannot determine a parameter (singular regressor or Jacobian)."""


class EstimationError(PhysidError, ValueError):
    """An estimator cannot run on the given data (no excitation, too few rows)."""


class SimulationError(PhysidError, RuntimeError):
    """The integrator failed (stiff system, blow-up); the message says which settings to change."""


class MissingDependencyError(PhysidError, ImportError):
    """An optional dependency (Dask, h5py, pinocchio ...) is needed for the requested feature.

    The message names the extra to install, e.g. ``pip install "physid[dask]"``.
    """
