"""One registry of estimators: build any estimator from its method name.

``make("algebraic", "msd", window=0.05)`` is how the CLI, the sweeps and the paper experiments
build estimators; a new method registers itself with `register` and is then available to `make`
and `methods` (the library). The command line and the sweeps accept fixed lists — ``physid
estimate``: algebraic, rls; ``physid identify``: input-error, idim-*; sweeps: algebraic, rls — so
a registered method reaches the CLI only once its verb lists it. Built in: ``"algebraic"``,
``"rls"`` (linear ODE models), ``"input-error"`` and the IDIM methods ``"idim-ols"``,
``"idim-wls"``, ``"idim-iv"`` (chain models); each is imported only when `make` builds one, and no
estimator module imports this registry.

Examples
--------
>>> from physid.estimators import make, methods
>>> est = make("rls", "msd", forgetting=0.99)
>>> type(est).__name__, est.forgetting
('RecursiveLeastSquares', 0.99)
>>> {"algebraic", "rls", "input-error"} <= set(methods())
True
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..errors import InputError

__all__ = ["make", "register", "methods", "method_kind", "KINDS"]

#: What a method estimates: linear ODE coefficients or a chain (rigid-body) model's parameters.
KINDS = ("linear_ode", "chain", "structure")


@dataclass(frozen=True)
class _Entry:
    name: str
    factory: Callable[..., Any]
    kind: str


_REGISTRY: dict[str, _Entry] = {}


def register(name: str, factory: Callable[..., Any], *, kind: str) -> None:
    """Make an estimator available under a method name.

    Parameters
    ----------
    name : str
        Method name (lower case, words joined by ``-``), e.g. ``"idim-ols"``.
    factory : callable
        ``factory(model, **settings)`` returning an unfitted estimator (usually the class).
    kind : {"linear_ode", "chain"}
        What kind of model the method identifies.

    Raises
    ------
    InputError
        An empty name, an unknown kind, or a name already registered to another factory.
    """
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"name must be a non-empty string; got {name!r}.")
    if kind not in KINDS:
        raise InputError(f"kind must be one of {KINDS}; got {kind!r}.")
    if not callable(factory):
        raise InputError(f"factory must be callable; got {type(factory).__name__}.")
    old = _REGISTRY.get(name)
    if old is not None and old.factory is not factory:
        raise InputError(
            f"method {name!r} is already registered (to {old.factory!r}); choose another name."
        )
    _REGISTRY[name] = _Entry(name, factory, kind)


def methods(kind: str | None = None) -> tuple[str, ...]:
    """Registered method names.

    Parameters
    ----------
    kind : {"linear_ode", "chain"}, optional
        Only the methods for this kind of model.

    Returns
    -------
    tuple of str
        Names in registration order.
    """
    return tuple(e.name for e in _REGISTRY.values() if kind is None or e.kind == kind)


def method_kind(method: str) -> str:
    """The kind (``"linear_ode"`` or ``"chain"``) of a registered method.

    Parameters
    ----------
    method : str
        A registered method name.

    Returns
    -------
    str
        One of `KINDS`.
    """
    return _entry(method).kind


def _entry(method: str) -> _Entry:
    entry = _REGISTRY.get(method)
    if entry is None:
        raise InputError(f"method must be one of {list(_REGISTRY)}; got {method!r}.")
    return entry


def make(method: str, model, **settings):
    """Build an (unfitted) estimator from its method name.

    Parameters
    ----------
    method : str
        A registered method: ``"algebraic"``, ``"rls"``, ``"input-error"``, … (see `methods`).
    model : str, path or model object
        The model to identify (``"msd"``, a TOML path, a `LinearODEModel` or a `ChainModel`).
    **settings
        The estimator's settings (its ``__init__`` keywords).

    Returns
    -------
    estimator
        Call ``fit(recording)`` on it; the result is in ``result_``.

    Raises
    ------
    InputError
        An unknown method, or a setting the estimator does not have.
    """
    entry = _entry(method)
    try:
        return entry.factory(model, **settings)
    except TypeError as exc:
        if "unexpected keyword argument" not in str(exc):
            raise
        raise InputError(
            f"method {method!r} does not take the setting(s) given: {exc}. Its settings are the "
            f"keywords of {getattr(entry.factory, '__name__', entry.factory)!r}."
        ) from None


def _algebraic(model, **settings):
    from .algebraic import AlgebraicEstimator

    return AlgebraicEstimator(model, **settings)


def _rls(model, **settings):
    from .recursive import RecursiveLeastSquares

    return RecursiveLeastSquares(model, **settings)


def _input_error(model, **settings):
    from .input_error import InputErrorEstimator

    return InputErrorEstimator(model, **settings)


def _structure(method: str) -> Callable[..., Any]:
    """The factory of a structure estimator (``"equation-error"`` or ``"output-error"``)."""

    def factory(model, **settings):
        from .equation_error import EquationErrorEstimator
        from .output_error import OutputErrorEstimator

        cls = EquationErrorEstimator if method == "equation-error" else OutputErrorEstimator
        return cls(model, **settings)

    factory.__name__ = f"structure[{method}]"
    return factory


def _idim(method: str) -> Callable[..., Any]:
    """The factory of IDIM-``method``; a model given by name is loaded first."""

    def factory(model, **settings):
        from .idim import IDIMEstimator

        if isinstance(model, str):
            from ..models import load_model

            model = load_model(model)
        return IDIMEstimator(model, method, **settings)

    factory.__name__ = f"IDIMEstimator[{method}]"
    return factory


# The built-in methods. Each factory imports its estimator when it is first called (so that
# importing the registry stays cheap); no estimator module imports this registry.
register("algebraic", _algebraic, kind="linear_ode")
register("rls", _rls, kind="linear_ode")
register("input-error", _input_error, kind="chain")
register("equation-error", _structure("equation-error"), kind="structure")
register("output-error", _structure("output-error"), kind="structure")
for _method in ("ols", "wls", "iv"):
    register(f"idim-{_method}", _idim(_method), kind="chain")
