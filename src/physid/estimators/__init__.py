"""Estimators: input-error (inverse model), algebraic sliding window, recursive least squares.

All follow scikit-learn's shape: settings in ``__init__``, ``fit(recording)`` returns the
estimator, and the fitted result (a frozen dataclass with ``parameters``, ``success``,
``message``, ``summary()``, ``to_dict()`` and ``plot()``) is in ``result_``.
"""

from .algebraic import (
    AlgebraicEstimator,
    AlgebraicResult,
    StreamingAlgebraicEstimator,
    algebraic_estimates,
)
from .idim import ConditionWarning, IDIMEstimator, IDIMResult
from .input_error import BoundWarning, FilterWarning, InputErrorEstimator, InputErrorResult
from .recursive import (
    RecursiveLeastSquares,
    RecursiveResult,
    StreamingRecursiveEstimator,
    StreamingRLS,
    StreamingStateVariableFilter,
    build_regression,
    rls_update,
)
from .results import ResultMixin

__all__ = [
    "InputErrorEstimator",
    "InputErrorResult",
    "FilterWarning",
    "BoundWarning",
    "AlgebraicEstimator",
    "AlgebraicResult",
    "StreamingAlgebraicEstimator",
    "algebraic_estimates",
    "RecursiveLeastSquares",
    "RecursiveResult",
    "StreamingRLS",
    "StreamingRecursiveEstimator",
    "StreamingStateVariableFilter",
    "rls_update",
    "build_regression",
    "ResultMixin",
    "IDIMEstimator",
    "IDIMResult",
    "ConditionWarning",
]
