"""Behaviour shared by the estimator classes: scikit-learn's parameter protocol and plain arrays.

Every estimator keeps its settings in ``__init__`` (nothing else happens there) and inherits

* ``get_params()`` / ``set_params(**settings)`` — the settings by name, read from the signature of
  ``__init__`` (as scikit-learn's ``BaseEstimator``);
* a ``repr`` that shows the settings that differ from their defaults;
* ``fit_arrays(t, **channels)`` — the one documented path for plain arrays: the arrays become a
  `physid.Recording` with those channel names and go through ``fit``.
"""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np

from ..errors import InputError

__all__ = ["EstimatorMixin"]


def _same(a, b) -> bool:
    try:
        return bool(a is b or a == b)
    except Exception:  # arrays, models: compare by identity only
        return a is b


class EstimatorMixin:
    """``get_params``, ``set_params``, ``repr`` and ``fit_arrays`` for estimator classes."""

    @classmethod
    def _param_names(cls) -> list[str]:
        sig = inspect.signature(cls.__init__)
        return [
            name
            for name, p in sig.parameters.items()
            if name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
        ]

    def get_params(self, deep: bool = False) -> dict[str, Any]:
        """The estimator's settings.

        Parameters
        ----------
        deep : bool
            Accepted for scikit-learn compatibility (settings are not nested).

        Returns
        -------
        dict
            name -> value of every ``__init__`` argument.
        """
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **settings):
        """Change settings by name (as in ``__init__``); returns the estimator.

        Parameters
        ----------
        **settings
            New values of ``__init__`` arguments.

        Returns
        -------
        estimator
            ``self``, for chaining.

        Raises
        ------
        InputError
            A name that is not a setting of this estimator.
        """
        allowed = self._param_names()
        bad = sorted(set(settings) - set(allowed))
        if bad:
            raise InputError(
                f"{type(self).__name__} has no setting(s) {bad}; its settings are {allowed}."
            )
        for name, value in settings.items():
            setattr(self, name, value)
        return self

    def __repr__(self) -> str:
        sig = inspect.signature(type(self).__init__)
        parts = []
        for name in self._param_names():
            value = getattr(self, name, None)
            default = sig.parameters[name].default
            if default is not inspect.Parameter.empty and _same(value, default):
                continue
            if hasattr(value, "name") and not isinstance(value, (str, int, float)):
                text = f"<{type(value).__name__} {value.name!r}>"
            else:
                text = repr(value)
            parts.append(f"{name}={text}")
        return f"{type(self).__name__}({', '.join(parts)})"

    def fit_arrays(self, t, **channels):
        """Fit plain arrays: ``fit_arrays(t, u=u, x=x)`` (or ``q1=…, tau1=…`` for chains).

        Parameters
        ----------
        t : array_like, shape (n_samples,) [s]
            Sample times.
        **channels : array_like, shape (n_samples,)
            One array per channel, named as the recording channels the estimator reads.

        Returns
        -------
        estimator
            ``self`` with ``result_``.
        """
        from ..signals.recording import Recording

        if not channels:
            raise InputError(
                "fit_arrays(t, **channels) needs the channels by name, e.g. "
                "fit_arrays(t, u=u, x=x); got none."
            )
        from .._validate import as_1d
        from ..errors import ShapeError

        times = as_1d(t, "t")
        names = list(channels)
        columns = []
        for n in names:  # each channel by name: not numpy's "the array at index 0 has size ..."
            col = as_1d(channels[n], n)
            if col.size != times.size:
                raise ShapeError(
                    f"channel {n!r} has {col.size} samples but t has {times.size}; give one "
                    "value per sample time."
                )
            columns.append(col)
        return self.fit(Recording(times, np.column_stack(columns), names))
