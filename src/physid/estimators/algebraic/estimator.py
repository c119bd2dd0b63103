"""The algebraic estimator's entry points: `algebraic_estimates` and `AlgebraicEstimator`."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import numpy as np

from ..._validate import check_positive, check_signal_pair
from ...errors import EstimationError, InputError, SamplingError
from ...models.linear_ode import as_linear_ode_model
from .._linear import check_distinct_channels, check_distinct_signals
from .._regression import check_excitation
from ..base import EstimatorMixin
from ..plausibility import check_magnitude
from .kernels import DEFAULT_INTERPOLATION_DEGREE
from .plan import DEFAULT_GUARD, FINAL_RULES, AlgebraicSettings, _Plan, _settings_plan
from .result import AlgebraicResult, _make_result
from .solve import _run


def _check_signals(model, plan: _Plan, u, y) -> None:
    """Refuse records that cannot determine the unknowns (before any window is computed)."""
    n = u.size
    if plan.L > n - 1:
        raise SamplingError(
            f"window = {plan.window:g} s ({plan.L} intervals) is longer than the record "
            f"({n} samples, {(n - 1) * plan.dt:g} s). Shorten the window or record longer."
        )
    u_zero = not np.any(u)
    if u_zero and not np.any(y):
        raise EstimationError(
            "no excitation: the input u and the output y are identically zero (zero input and "
            "zero initial state), so every window integral vanishes. Record a response to a "
            "non-zero input."
        )
    if u_zero and any(kind == "b" for kind, _ in plan.columns):
        raise EstimationError(
            f"the input u is identically zero, so the input coefficient(s) "
            f"{[nm for nm, (k, _) in zip(plan.names, plan.columns, strict=True) if k == 'b']} "
            "cannot be estimated; give them as known or excite the system."
        )
    check_distinct_signals(u, y)


def algebraic_estimates(
    u,
    y,
    dt: float,
    model="msd",
    *,
    t_start: float = 0.0,
    settings: AlgebraicSettings | None = None,
    **kwargs,
) -> AlgebraicResult:
    """Algebraic sliding-window estimates of a linear ODE's coefficients at every sample.

    Parameters
    ----------
    u, y : array_like, shape (n_samples,)
        Input and output sampled every ``dt`` (for the built-in MSD ``u = F/m`` [m/s²], ``y = x``
        [m]).
    dt : float [s]
        Sample period.
    model : "msd", path to a TOML model file, or LinearODEModel
        The linear ODE ``Σ a_i y^(i) = Σ b_i u^(i)`` (``a_n = 1``).
    t_start : float [s]
        Time of the first sample (only labels the result's ``t``).
    settings : AlgebraicSettings, optional
        All settings at once (default `AlgebraicSettings()`).
    **kwargs
        Any `AlgebraicSettings` field by name (``window=0.2``, ``mu=4``, …), overriding
        ``settings``.

    Returns
    -------
    AlgebraicResult

    Raises
    ------
    SamplingError
        The window is longer than the record or shorter than the kernels need.
    InputError
        Unknown coefficient names, Simpson with an odd number of intervals, bad settings.
    EstimationError
        No excitation (``u ≡ 0`` and ``y ≡ 0``), ``u ≡ 0`` with an input coefficient unknown, or
        an input proportional to the output.
    IdentifiabilityError
        A coefficient whose window integrals carry no information (e.g. a constant input).

    Notes
    -----
    Oueslati et al. (2011), section 4, derived for any order (see the module docstring and
    ``docs/algebraic.md`` for the corrections to eq. 17-20).

    Examples
    --------
    ÿ + 2ẏ + 5y = u with u = sin(7t), y(0) = ẏ(0) = 0 (closed form from scipy's ``lsim``):

    >>> from scipy import signal
    >>> from physid.models import msd_model
    >>> msd = msd_model()  # ẍ + θ1 ẋ + θ2 x = u, θ1 and θ2 unknown
    >>> t = np.arange(0, 2, 1e-3); u = np.sin(7 * t)
    >>> y = signal.lsim(([1.0], [1.0, 2.0, 5.0]), u, t, interp=True)[1]
    >>> res = algebraic_estimates(u, y, 1e-3, msd, window=0.2)
    >>> round(res.parameters["theta1"], 3), round(res.parameters["theta2"], 3)
    (2.0, 5.0)
    """
    base = settings if settings is not None else AlgebraicSettings()
    bad = sorted(set(kwargs) - set(AlgebraicSettings.names()))
    if bad:
        raise InputError(
            f"unknown setting(s) {bad} for algebraic_estimates; allowed: "
            f"{sorted(AlgebraicSettings.names())}."
        )
    s = base.replace(**kwargs) if kwargs else base
    dt = check_positive(dt, "dt")
    final_fraction = float(s.final_fraction)
    if not (0.0 < final_fraction <= 1.0):
        raise InputError(f"final_fraction must lie in (0, 1]; got {s.final_fraction!r}.")
    if s.final not in FINAL_RULES:
        raise InputError(f"final must be one of {FINAL_RULES}; got {s.final!r}.")
    u, y = check_signal_pair(u, y)
    check_magnitude((u, y), ("u", "y"))
    model = as_linear_ode_model(model)
    y = y - model.known_output_offset()  # a held offset (identify = false) is removed (a copy)
    plan = _settings_plan(model, dt, s)
    _check_signals(model, plan, u, y)
    n = u.size
    theta, valid, level, _, equations = _run(plan, u, y, 0, n, np.empty(0))
    _check_window_excitation(plan, equations, valid, model)
    t = t_start + dt * np.arange(n)
    return _make_result(
        plan,
        t,
        theta,
        valid,
        level,
        final_fraction,
        s.final,
        equations,
        model=model,
        settings=s,
        signals=(t, u, y),
    )


def _check_window_excitation(plan: _Plan, equations, valid, model) -> None:
    """Refuse a record whose window equations cannot determine every unknown.

    The rows of every valid full window's system are one regression ``A α = r`` (dimensionless
    unknowns); the recursive estimator's unit-free tests apply unchanged: a zero column, a column
    whose share ``‖A_i‖·|α_i| / ‖r‖`` is below 1e-6 (e.g. the ẋ kernel on a constant record), and
    linearly dependent columns. A constant input that has settled gives θ1 ≈ 1e-14 "with success"
    otherwise.
    """
    A, rhs = equations
    n = valid.size
    use = valid.copy()
    use[: plan.span] = False
    if not use.any():
        return
    X = np.moveaxis(A[:, :, -n:][:, :, use], 1, -1).reshape(-1, plan.p)
    Y = rhs[:, -n:][:, use].reshape(-1)
    nominal = []
    for (kind, i), name in zip(plan.columns, plan.names, strict=True):
        try:
            v = float(model.parameters[name]) if kind != "o" else np.nan  # δ' is not o
        except (KeyError, TypeError, ValueError):
            v = np.nan
        nominal.append(v * plan.window ** (plan.order - i))  # α_i = a_i T^(n−i)
    ok = np.isfinite(X).all(axis=1) & np.isfinite(Y)
    if ok.sum() >= plan.p:
        check_excitation(X[ok], plan.names, Y[ok], np.array(nominal))


class AlgebraicEstimator(EstimatorMixin):
    """Algebraic (Fliess / Sira-Ramírez) sliding-window estimator, scikit-learn style.

    Parameters
    ----------
    model : "msd", path to a TOML model file, or LinearODEModel
        The linear ODE ``Σ a_i y^(i) = Σ b_i u^(i)`` (``a_n = 1``).
    window : float [s]
        Window length ``T`` (rounded to ``L = round(T / dt)`` sample intervals).
    mu : int, optional
        Smallest power ``ν`` of ``1/s`` (default and minimum ``order + 1``, at most `MAX_MU`).
    integration : {"exact", "simpson", "trapezoid"}
        Quadrature of the window integrals; "simpson" is the paper's eq. 21.
    block : int
        Least squares over ``block`` windows.
    block_stride : int
        Spacing of the block's windows in samples.
    extra_derivatives : int
        ``d/ds`` applied beyond the ``order`` needed to annihilate the initial conditions.
    n_equations : int, optional
        Equations per window (default the number of unknowns).
    unknown : sequence of str, optional
        Coefficients to estimate (default ``model.unknown`` less the names in ``known``).
    known : dict, optional
        Values of known coefficients overriding ``model.parameters``.
    guard : float
        Determinant guard threshold relative to the running median (0 disables it).
    guard_window : int, optional
        Windows in the running median of the guard (default ``2 L + 1``).
    expanding : bool
        Estimate on the growing window ``[0, t0]`` before the first full window.
    interpolation_degree : int
        Degree of the local interpolant of the "exact" rule.
    final_fraction : float in (0, 1]
        The final estimate uses the valid full windows in this trailing fraction of the record.
    final : {"lstsq", "median", "bias-compensated"}
        Pooled least squares over the valid windows (default), their median, or bias-compensated
        pooled least squares over every full window (see `AlgebraicSettings`).

    Attributes
    ----------
    result_ : AlgebraicResult
        Set by `fit` / `fit_arrays`.

    Notes
    -----
    Every setting is described in full in `AlgebraicSettings`. Standard errors (``result_.stderr``)
    propagate white output noise through the window kernels exactly, overlap of the windows
    and the second-order noise × noise term included (`_pooled_stderr`); the default
    (``final="lstsq"``) withholds them where its estimate is biased at their scale
    (`_withhold_if_biased`), ``final="median"`` has none (``stderr_reason`` says so in both
    cases). Measured coverage: benchmarks/bench_coverage.py.

    Examples
    --------
    Noise-free ẍ + 2 ẋ + 100 x = sin(10 t), 1 s at 1 kHz (ω0 = 10 rad/s, ζ = 0.1):

    >>> from scipy import signal
    >>> from physid import Recording
    >>> t = np.arange(1000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> est = AlgebraicEstimator("msd", window=0.05).fit(Recording(t, np.c_[u, x], ["u", "x"]))
    >>> d = est.result_.derived
    >>> round(d["natural_frequency"], 4), round(d["damping_ratio"], 4)
    (10.0, 0.1)
    """

    def __init__(
        self,
        model="msd",
        *,
        window: float = 0.05,
        mu: int | None = None,
        integration: str = "exact",
        block: int = 1,
        block_stride: int = 1,
        extra_derivatives: int = 0,
        n_equations: int | None = None,
        unknown: Sequence[str] | None = None,
        known: Mapping[str, float] | None = None,
        guard: float = DEFAULT_GUARD,
        guard_window: int | None = None,
        expanding: bool = False,
        interpolation_degree: int = DEFAULT_INTERPOLATION_DEGREE,
        final_fraction: float = 1.0,
        final: str = "lstsq",
    ):
        self.model = model
        self.window = window
        self.mu = mu
        self.integration = integration
        self.block = block
        self.block_stride = block_stride
        self.extra_derivatives = extra_derivatives
        self.n_equations = n_equations
        self.unknown = unknown
        self.known = known
        self.guard = guard
        self.guard_window = guard_window
        self.expanding = expanding
        self.interpolation_degree = interpolation_degree
        self.final_fraction = final_fraction
        self.final = final

    @property
    def settings(self) -> AlgebraicSettings:
        """The current settings as an `AlgebraicSettings`."""
        return AlgebraicSettings(**{k: getattr(self, k) for k in AlgebraicSettings.names()})

    def fit(self, recording) -> AlgebraicEstimator:
        """Estimate from a uniformly sampled `Recording`.

        Parameters
        ----------
        recording : Recording
            Channels: the model's input and output (the MSD: ``u`` and ``x`` or ``y``).

        Returns
        -------
        AlgebraicEstimator
            ``self``, with ``result_``.
        """
        names = getattr(recording, "names", None)
        if names is None:
            raise InputError(
                f"recording must be a physid Recording; got {type(recording).__name__}. "
                "Use fit_arrays(t, u=u, x=y) for plain arrays."
            )
        model = as_linear_ode_model(self.model)
        in_name, out = model.recording_channels(names)
        model.check_units(recording)  # a force [N] for the normalised msd is an error
        check_distinct_channels(in_name, out)
        dt = recording.dt
        self.result_ = algebraic_estimates(
            recording[in_name],
            recording[out],
            dt,
            model,
            t_start=float(recording.t[0]),
            settings=self.settings,
        )
        return self

    def fit_arrays(self, *args, **channels) -> AlgebraicEstimator:
        """Fit plain arrays: ``fit_arrays(t, u=u, x=y)`` (see `EstimatorMixin.fit_arrays`).

        Parameters
        ----------
        *args
            ``t`` (sample times [s]); the old form ``fit_arrays(u, y, dt[, t_start])`` still
            works and warns (DeprecationWarning).
        **channels
            The model's input and output channels by name.

        Returns
        -------
        AlgebraicEstimator
            ``self``, with ``result_``.
        """
        if len(args) in (3, 4) and not channels:
            warnings.warn(
                "fit_arrays(u, y, dt) is deprecated; use fit_arrays(t, u=u, x=y) (the one "
                "plain-array form of every estimator).",
                DeprecationWarning,
                stacklevel=2,
            )
            u, y, dt = args[:3]
            t_start = args[3] if len(args) == 4 else 0.0
            self.result_ = algebraic_estimates(
                u, y, dt, self.model, t_start=t_start, settings=self.settings
            )
            return self
        if len(args) != 1:
            raise InputError(
                "fit_arrays takes the sample times and the channels by name: "
                "fit_arrays(t, u=u, x=y)."
            )
        return super().fit_arrays(args[0], **channels)
