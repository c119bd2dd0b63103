"""Estimators: input-error (inverse model), algebraic sliding window, recursive least squares.

All follow scikit-learn's shape: settings in ``__init__`` (``get_params``/``set_params``),
``fit(recording)`` (or ``fit_arrays(t, **channels)`` for plain arrays) returns the estimator, and
the fitted result is in ``result_``: one schema for every method (`physid.estimators.results`:
``names``, ``parameters`` (fitted only), ``derived``, ``stderr``/``stderr_reason``, ``history``,
``success``, ``message``, ``units``, ``summary()``, ``to_dict()``, ``to_pandas()``, ``plot()``,
``predict(recording)``). ``make(method, model, **settings)`` builds any registered method.
"""

from .algebraic import (
    AlgebraicEstimator,
    AlgebraicResult,
    AlgebraicSettings,
    StreamingAlgebraicEstimator,
    algebraic_estimates,
)
from .base import EstimatorMixin
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
from .registry import make, methods, register
from .results import ParameterDict, ResultMixin

__all__ = [
    "InputErrorEstimator",
    "InputErrorResult",
    "FilterWarning",
    "BoundWarning",
    "AlgebraicEstimator",
    "AlgebraicResult",
    "AlgebraicSettings",
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
    "ParameterDict",
    "EstimatorMixin",
    "make",
    "register",
    "methods",
]
