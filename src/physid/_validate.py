"""The one place for shape, finiteness and uniform-sampling checks.

Every public function validates its user-facing arrays through these helpers so that the messages
are uniform: they name the argument, the rule, what was received and the fix.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence

import numpy as np

from .errors import InputError, SamplingError, ShapeError, arg

__all__ = [
    "as_2d",
    "as_1d",
    "check_finite",
    "check_time",
    "sample_period",
    "check_positive",
    "check_in_range",
    "check_length",
    "check_signal_pair",
    "check_int",
    "per_joint",
    "parameter_vector",
]


def _name(name: str) -> str:
    """``name`` marked as a Python argument (see `physid.errors.arg`) when it is one."""
    return arg(name) if name.isidentifier() else name


#: Relative tolerance on the spread of sample intervals before sampling counts as non-uniform.
UNIFORM_RTOL = 1e-6


def as_1d(x, name: str, *, dtype=float) -> np.ndarray:
    """Return ``x`` as a new 1-D float array, or raise `ShapeError` naming ``name``."""
    try:
        arr = np.array(x, dtype=dtype, copy=True)
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"{_name(name)} must be numeric; could not convert it to numbers ({exc})."
        ) from None
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ShapeError(f"{_name(name)} must be one-dimensional; got shape {arr.shape}.")
    return arr


def as_2d(x, name: str, *, n_channels: int | None = None, dtype=float) -> np.ndarray:
    """Return ``x`` as a new array of shape ``(n_samples, n_channels)``.

    A 1-D input is one channel. ``n_channels``, when given, must match.
    """
    try:
        arr = np.array(x, dtype=dtype, copy=True)
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"{_name(name)} must be numeric; could not convert it to numbers ({exc})."
        ) from None
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ShapeError(
            f"{_name(name)} must have shape (n_samples, n_channels) or (n_samples,); "
            f"got shape {arr.shape}."
        )
    if n_channels is not None and arr.shape[1] != n_channels:
        raise ShapeError(
            f"{_name(name)} must have {n_channels} column(s) (one per channel); got shape {arr.shape}."
        )
    return arr


def check_finite(arr: np.ndarray, name: str, channel_names: Sequence[str] | None = None) -> None:
    """Raise `InputError` naming the first channel and row holding NaN or inf."""
    bad = ~np.isfinite(arr)
    if not bad.any():
        return
    rows, cols = np.nonzero(bad.reshape(arr.shape[0], -1))
    row, col = int(rows[0]), int(cols[0])
    where = f"channel {channel_names[col]!r}" if channel_names is not None else f"column {col}"
    value = arr.reshape(arr.shape[0], -1)[row, col]
    raise InputError(
        f"{_name(name)} holds a non-finite value ({value}) in {where}, row {row} "
        f"({int(bad.sum())} non-finite value(s) in all); remove or interpolate those samples first."
    )


def check_time(t, name: str = "t", *, min_samples: int = 2) -> np.ndarray:
    """Validate a time vector [s]: 1-D, finite, strictly increasing, >= ``min_samples`` long."""
    t = as_1d(t, name)
    check_finite(t[:, None], name)
    if t.size < min_samples:
        raise SamplingError(f"{name} must hold at least {min_samples} samples; got {t.size}.")
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0))
        raise SamplingError(
            f"{name} must be strictly increasing; {name}[{i + 1}] = {t[i + 1]!r} follows "
            f"{name}[{i}] = {t[i]!r}. Sort the samples and drop duplicates."
        )
    return t


def sample_period(t: np.ndarray, name: str = "t", *, rtol: float = UNIFORM_RTOL) -> float:
    """Return the sample period [s] of a uniform time vector, or raise `SamplingError`.

    The period is the least-squares slope of ``t`` against the sample index k = 0 … n−1,
    ``T = Σ (k − k̄)(t_k − t_0) / Σ (k − k̄)²`` with ``Σ (k − k̄)² = n (n² − 1) / 12``: it uses every
    sample (the end points alone carry their own rounding), so a grid built by accumulation (with
    rounding drift) still counts as uniform and gets its best period. Sampling is uniform when no
    interval differs from ``T`` by more than ``rtol · T``.

    Parameters
    ----------
    t : array_like (n_samples,) [s]
        Strictly increasing sample times.
    name : str
        The argument's name, for the message.
    rtol : float
        Relative tolerance on the spread of the intervals.

    Returns
    -------
    float
        The sample period T [s].

    Examples
    --------
    >>> sample_period([0.0, 0.5, 1.0, 1.5])
    0.5
    """
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        raise SamplingError(
            f"{_name(name)} needs at least 2 samples to define a sample period; got {t.size}."
        )
    n = t.size
    if n == 2:
        period = float(t[1] - t[0])
    else:
        # T = T_ends + slope of the residual r_k = (t_k − t_0) − k·T_ends: the same least-squares
        # slope, but summed over the tiny residuals, so it keeps full precision (an exactly
        # uniform grid gets exactly its step back).
        end_points = (t[-1] - t[0]) / (n - 1)
        k = np.arange(n, dtype=float)
        residual = (t - t[0]) - k * end_points
        period = float(end_points + (k - 0.5 * (n - 1)) @ residual / (n * (n * n - 1.0) / 12.0))
    deviation = np.abs(np.diff(t) - period)
    worst = float(deviation.max())
    if not worst <= rtol * period:
        i = int(deviation.argmax())
        raise SamplingError(
            f"{_name(name)} is not uniformly sampled: the interval after sample {i} is "
            f"{t[i + 1] - t[i]:.6g} s against a mean period of {period:.6g} s "
            f"(worst relative deviation {worst / period:.3g}, "
            f"tolerance {rtol:g}). Resample onto a uniform grid first "
            f"({arg('resample', 'True', cli='')} when loading, or Recording.resample())."
        )
    return float(period)


def check_positive(value, name: str, *, allow_zero: bool = False) -> float:
    """Return ``value`` as float if it is finite and > 0 (or >= 0), else raise `InputError`."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(
            f"{_name(name)} must be a number; got {value!r} of type {type(value).__name__}."
        ) from None
    ok = np.isfinite(v) and (v >= 0 if allow_zero else v > 0)
    if not ok:
        rule = ">= 0" if allow_zero else "> 0"
        raise InputError(f"{_name(name)} must be finite and {rule}; got {value!r}.")
    return v


def check_in_range(
    value, name: str, low: float, high: float, *, low_open=False, high_open=False
) -> float:
    """Return ``value`` as float if it lies in the interval, else raise `InputError`."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(
            f"{_name(name)} must be a number; got {value!r} of type {type(value).__name__}."
        ) from None
    lo_ok = v > low if low_open else v >= low
    hi_ok = v < high if high_open else v <= high
    if not (np.isfinite(v) and lo_ok and hi_ok):
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
        raise InputError(f"{_name(name)} must lie in {interval}; got {value!r}.")
    return v


def check_length(n_samples: int, needed: int, what: str, fix: str) -> None:
    """Raise `SamplingError` when a record of ``n_samples`` is shorter than ``needed``."""
    if n_samples < needed:
        raise SamplingError(
            f"{what} needs at least {needed} samples but the record has {n_samples}. {fix}"
        )


def check_signal_pair(u, y, name_u: str = "u", name_y: str = "y") -> tuple[np.ndarray, np.ndarray]:
    """Return input and output samples as new 1-D float arrays of equal length, all finite."""
    u = as_1d(u, name_u)
    y = as_1d(y, name_y)
    if u.size != y.size:
        raise ShapeError(
            f"{name_u} and {name_y} must have the same length; got {u.size} and {y.size}."
        )
    check_finite(u[:, None], name_u)
    check_finite(y[:, None], name_y)
    return u, y


def check_int(
    value,
    name: str,
    *,
    minimum: int | None = None,
    maximum: int | None = None,
    allow_none: bool = False,
    fix: str = "",
) -> int | None:
    """Return ``value`` as an ``int`` if it is an integer in range, else raise `InputError`.

    The one integer check: ``bool`` is refused (``True`` is not a count), a float is refused even
    when integral (``trials=1e3`` says "pass 1000"), and numpy integers are accepted.

    Parameters
    ----------
    value : int
        The value to check.
    name : str
        The argument's name, for the message.
    minimum, maximum : int, optional
        Inclusive bounds.
    allow_none : bool
        Let ``None`` through (returned as ``None``), for "default" arguments.
    fix : str
        A sentence appended to the message saying what to pass.

    Returns
    -------
    int or None
        The value as a Python ``int``.

    Raises
    ------
    InputError
        Not an integer, or outside the bounds.

    Examples
    --------
    >>> check_int(5, "trials", minimum=1)
    5
    >>> check_int(0, "trials", minimum=1)
    Traceback (most recent call last):
    ...
    physid.errors.InputError: trials must be an integer >= 1; got 0.
    """
    if value is None and allow_none:
        return None
    rule = "an integer"
    if minimum is not None and maximum is not None:
        rule += f" in [{minimum}, {maximum}]"
    elif minimum is not None:
        rule += f" >= {minimum}"
    elif maximum is not None:
        rule += f" <= {maximum}"
    if allow_none:
        rule += " (or None)"
    tail = f" {fix}" if fix else ""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        hint = ""
        if isinstance(value, numbers.Real) and not isinstance(value, bool):
            f = float(value)
            if np.isfinite(f) and f == int(f):
                hint = f" Pass {int(f)} (an int, not a float)."
        raise InputError(
            f"{_name(name)} must be {rule}; got {value!r} of type {type(value).__name__}."
            f"{hint}{tail}"
        )
    v = int(value)
    if (minimum is not None and v < minimum) or (maximum is not None and v > maximum):
        raise InputError(f"{_name(name)} must be {rule}; got {v}.{tail}")
    return v


def per_joint(value, name: str, n: int) -> np.ndarray:
    """One finite value per joint, as a new array of shape ``(n,)``.

    Used for every per-joint setting (PD gains ``kp``/``kd``, limits ...), so each bad input
    raises the same class with the same words wherever it enters.

    Parameters
    ----------
    value : float, array_like (n,) or mapping
        A scalar (the same value for every joint), ``n`` values in joint order, or a mapping
        naming every joint as ``{name}{j}`` or ``"{j}"`` (j = 1 … n), e.g. ``{"kp1": 50, "kp2": 40}``.
    name : str
        The argument's name, for the message (and the mapping keys).
    n : int
        Number of joints.

    Returns
    -------
    ndarray, shape (n,)
        A new float array.

    Raises
    ------
    ShapeError
        Neither a scalar nor ``n`` values.
    InputError
        Not numeric, a mapping that misses a joint, or a non-finite value.

    Examples
    --------
    >>> per_joint(2.0, "kp", 3)
    array([2., 2., 2.])
    >>> per_joint({"kp1": 1, "kp2": 4}, "kp", 2)
    array([1., 4.])
    """
    if isinstance(value, Mapping):
        keys = [f"{name}{j}" if f"{name}{j}" in value else str(j) for j in range(1, n + 1)]
        missing = [
            f"{name}{j}" for j, key in zip(range(1, n + 1), keys, strict=True) if key not in value
        ]
        extra = sorted(set(map(str, value)) - set(keys))
        if missing or extra:
            raise InputError(
                f"{_name(name)} given as a mapping must name every joint once as "
                f"'{name}1' … '{name}{n}'; missing {missing}, unknown {extra} in {dict(value)}."
            )
        value = [value[key] for key in keys]
    arr = as_1d(value, name)
    if arr.size == 1:
        arr = np.full(n, arr[0])
    if arr.size != n:
        raise ShapeError(
            f"{_name(name)} must hold one value per joint ({n}) or a single value for all; "
            f"got {arr.size}: {np.asarray(value).tolist()!r}."
        )
    check_finite(arr[:, None], name)
    return arr


def parameter_vector(params, names: Sequence[str], nominal, *, model: str = "") -> np.ndarray:
    """Model parameters ordered like ``names``: ``nominal`` overridden by ``params``.

    The one parameter-resolution rule of every model kind (`ChainModel.parameter_vector`,
    `LinearODEModel.parameter_values`).

    Parameters
    ----------
    params : None, mapping or array_like (n_parameters,)
        None: the nominal values; a mapping overrides some (``{"m2": 24.0}``); an array gives
        all, ordered like ``names`` (SI units).
    names : sequence of str
        Parameter names, in order.
    nominal : array_like (n_parameters,)
        Nominal values, ordered like ``names``.
    model : str
        The model's name, for the messages.

    Returns
    -------
    ndarray, shape (n_parameters,)
        A new array.

    Raises
    ------
    InputError
        Unknown names, a value that is not a number, or non-finite values.
    ShapeError
        An array of the wrong length.

    Examples
    --------
    >>> parameter_vector({"k": 4.0}, ["c", "k"], [1.0, 2.0])
    array([1., 4.])
    """
    names = list(names)
    theta = np.array(nominal, dtype=float, copy=True)
    of = f" for model {model!r}" if model else ""
    if params is None:
        return theta
    if isinstance(params, Mapping):
        bad = [k for k in params if k not in names]
        if bad:
            base = [k for k in bad if isinstance(k, str) and k.endswith("R") and k[:-1] in names]
            hint = (
                f" {base} are base parameters (regrouped combinations of standard ones, as an "
                "IDIM result holds them), not model parameters; a model takes standard "
                "parameters, e.g. the physically consistent estimate (consistent=True: "
                "result.derived), or predict with result.predict(recording)."
                if base
                else ""
            )
            raise InputError(
                f"{arg('params')} has unknown name(s) {bad}{of}; known parameters: {names}.{hint}"
            )
        for k, v in params.items():
            try:
                theta[names.index(k)] = float(v)
            except (TypeError, ValueError):
                raise InputError(f"params[{k!r}] must be a number; got {v!r}.") from None
    else:
        theta = as_1d(params, "params")
        if theta.size != len(names):
            raise ShapeError(
                f"{arg('params')} as an array must have {len(names)} entries ordered like "
                f"{names}; got {theta.size}. Pass a dict to override only some."
            )
    if not np.all(np.isfinite(theta)):
        bad = {k: float(v) for k, v in zip(names, theta, strict=True) if not np.isfinite(v)}
        raise InputError(f"{arg('params')} must be finite; got {bad}.")
    return theta
