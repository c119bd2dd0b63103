"""Estimation studies for the sweep engine: a model, a scenario and an estimator per trial.

`physid.analysis.montecarlo.run_sweep` runs any picklable ``trial(settings, seed) -> dict`` over a
grid × seeds on a backend (serial, process pool, Dask). This module builds that trial from three
parts, so that a sweep works for any linear-ODE model, not only the paper's MSD:

* a **scenario** ``scenario(settings, seed) -> Recording`` that simulates one noisy record
  (`SineScenario`: the model driven by ``u = A sin(Z ω_ref t)`` with white noise at an SNR);
* an **estimator**, built per trial from the settings' ``method`` and options
  (`make_estimator`, through `physid.estimators.make` when the registry is present);
* an `EstimationTrial` that fits the estimator to the record and reports, for every estimated
  and derived quantity, its final estimate (``NAME_final``) beside its truth (``NAME_true``, from
  the scenario), the relative error of the tracked quantity and the times it first reaches and
  then stays within the tolerance (`physid.analysis.metrics`).

`model_sweep` puts them together; the MSD study of Oueslati et al. (`physid.analysis.msd_study`)
is the same engine with the paper's scenario and column names.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

from .._validate import check_positive
from ..errors import InputError, arg
from .metrics import DEFAULT_TOLERANCE, convergence_times, estimate_trace
from .sweep_run import run_sweep
from .sweep_table import SweepResult

__all__ = [
    "SineScenario",
    "EstimationTrial",
    "make_estimator",
    "estimator_variants",
    "reference_frequency",
    "model_sweep",
    "run_estimator_sweep",
    "check_ratios",
    "check_record_length",
    "TIME_COLUMNS",
    "MIN_SAMPLES",
]

#: Columns of a study's table that are convergence times (NaN = not converged).
TIME_COLUMNS = ("t_first_hit", "t_settle")
#: Methods a linear-ODE sweep can compare.
LINEAR_ODE_METHODS = ("algebraic", "rls")
#: Fewest samples per record a sweep accepts (the estimators need far more; see their messages).
MIN_SAMPLES = 20


def check_record_length(duration: float, dt: float) -> None:
    """Refuse a record of fewer than `MIN_SAMPLES` samples (``duration / dt``), naming ``dt``.

    Parameters
    ----------
    duration : float [s]
        Record length.
    dt : float [s]
        Sample period.

    Raises
    ------
    InputError
        ``dt = 1 s leaves only 5 sample(s) in duration = 5 s; …``.
    """
    n = duration / dt
    if n < MIN_SAMPLES:
        raise InputError(
            f"{arg('dt')} = {dt:g} s leaves only {int(n)} sample(s) in "
            f"{arg('duration')} = {duration:g} s; a sweep needs at least {MIN_SAMPLES} "
            f"(the estimators many more): use a smaller {arg('dt')} or a longer "
            f"{arg('duration')}."
        )


def check_ratios(ratio: Sequence[float]) -> list[float]:
    """The input frequency ratios Z of a sweep as floats; refuses an empty list or Z ≤ 0 or NaN.

    Parameters
    ----------
    ratio : sequence of float
        Z = ω1 / ω_ref.

    Returns
    -------
    list of float
        The ratios.
    """
    values = [float(z) for z in ratio]
    if not values or any(not z > 0 for z in values):
        raise InputError(
            f"{arg('ratio')} must be a non-empty list of positive numbers; got {list(ratio)}."
        )
    return values


def run_estimator_sweep(
    trial: Callable,
    grid: Mapping[str, Sequence],
    *,
    label: str,
    censored_columns: Sequence[str] = TIME_COLUMNS,
    **run_options: Any,
) -> SweepResult:
    """`run_sweep` of an estimator study: every estimator configuration sees the same records.

    The grid's ``estimator`` axis shares its seeds (``shared_seed_axes``), so each (SNR, Z,
    trial) record is simulated once and fitted by every configuration: a paired comparison.

    Parameters
    ----------
    trial : callable
        ``trial(settings, seed) -> dict`` (an `EstimationTrial`).
    grid : mapping
        Axis name → values, with an ``estimator`` axis.
    label : str
        Progress label.
    censored_columns : sequence of str
        Convergence-time columns (NaN = not converged).
    **run_options
        ``trials``, ``seed``, ``scheduler``, ``workers``, ``chunksize``, ``scheduler_timeout``,
        ``progress``: see `physid.analysis.montecarlo.run_sweep`.

    Returns
    -------
    SweepResult
        One row per grid point × trial.
    """
    return run_sweep(
        trial,
        grid,
        shared_seed_axes=("estimator",),
        censored_columns=censored_columns,
        label=label,
        **run_options,
    )


@lru_cache(maxsize=8)
def _load(model: str):
    """A linear-ODE model by built-in name or file path, loaded once per process."""
    from ..models import load_model
    from ..models.linear_ode import as_linear_ode_model

    return as_linear_ode_model(load_model(model))


def reference_frequency(model) -> float:
    """The frequency [rad/s] a sweep's ratio Z is relative to: ω_ref = |a_0|^(1/n).

    For a monic denominator that is the geometric mean of the poles' magnitudes; for the MSD it is
    the undamped natural frequency ω0 = √θ2.

    Parameters
    ----------
    model : LinearODEModel
        The model (nominal parameters).

    Returns
    -------
    float
        ω_ref [rad/s].

    Raises
    ------
    InputError
        ``a_0 = 0`` (an integrator has no such frequency): give the scenario a
        ``reference_frequency``.
    """
    a, _ = model.coefficients()
    n = len(a) - 1
    if not a[0]:
        raise InputError(
            f"model {model.name!r} has a_0 = 0 (an integrator), so the ratio Z has no natural "
            f"reference; pass {arg('reference_frequency', 'W')} [rad/s] to the scenario."
        )
    return float(abs(a[0]) ** (1.0 / n))


@dataclass(frozen=True)
class SineScenario:
    """One open-loop record of a linear-ODE model under ``u = A sin(Z ω_ref t)`` plus noise.

    Picklable (the model travels as its name or path and is loaded once per worker process).

    Parameters
    ----------
    model : str
        A built-in model name (``"msd"``) or the path of a linear-ODE model file.
    duration : float [s]
        Record length.
    dt : float [s]
        Sample period.
    amplitude : float
        A, in the unit of the input.
    reference_frequency : float [rad/s], optional
        ω_ref; default `reference_frequency` of the model (ω0 for an MSD).

    Notes
    -----
    Called as ``scenario(settings, seed)``: ``settings["ratio"]`` is Z (default 1) and
    ``settings["snr_db"]`` the SNR of the white measurement noise (None: clean), seeded by
    ``seed``. The record's metadata holds ``truth``: the model's nominal parameters and, for a
    second-order model, its natural frequency and damping ratio.
    """

    model: str
    duration: float = 5.0
    dt: float = 1e-3
    amplitude: float = 1.0
    reference_frequency: float | None = None

    def __post_init__(self):
        check_positive(self.duration, "duration")
        check_positive(self.dt, "dt")
        check_positive(self.amplitude, "amplitude")
        if self.reference_frequency is not None:
            check_positive(self.reference_frequency, "reference_frequency")
        check_record_length(self.duration, self.dt)

    def truth(self) -> dict[str, float]:
        """The values the estimates are compared with: nominal parameters (+ ω0, ζ for order 2).

        Returns
        -------
        dict
            name → true value.
        """
        model = _load(self.model)
        truth = dict(model.parameters)
        if model.order == 2 and len(model.a_names) == 2:
            from ..models.linear_ode import natural_frequency_damping

            a0, a1 = (truth[n] for n in model.a_names)
            if a0 > 0:
                w0, zeta = natural_frequency_damping(a1, a0)
                truth["natural_frequency"] = float(w0)
                truth["damping_ratio"] = float(zeta)
        return truth

    def __call__(self, settings: Mapping[str, Any], seed: int):
        from ..signals.excitation import Sinusoid
        from ..simulate import simulate_linear_ode

        model = _load(self.model)
        w_ref = self.reference_frequency or reference_frequency(model)
        ratio = check_positive(settings.get("ratio", 1.0), "ratio")
        snr = settings.get("snr_db")
        return simulate_linear_ode(
            model,
            duration=self.duration,
            dt=self.dt,
            input=Sinusoid(self.amplitude, ratio * w_ref),
            snr_db=None if snr is None else float(snr),
            rng=None if snr is None else int(seed),
            metadata={"truth": self.truth(), "ratio": ratio, "reference_frequency": w_ref},
        )


def estimator_variants(
    methods: Sequence[str] = LINEAR_ODE_METHODS,
    *,
    windows: Sequence[float] = (0.05,),
    forgettings: Sequence[float] = (1.0,),
) -> list[dict]:
    """Estimator configurations for a sweep: algebraic × windows and rls × forgetting factors.

    Parameters
    ----------
    methods : sequence of {"algebraic", "rls"}
        The methods to compare.
    windows : sequence of float [s]
        Algebraic window lengths T.
    forgettings : sequence of float
        RLS forgetting factors λ in (0, 1].

    Returns
    -------
    list of dict
        One grid value per configuration: ``{"method", "window", "forgetting"}`` (None where a
        setting does not apply).

    Examples
    --------
    >>> estimator_variants(["algebraic", "rls"], windows=[0.05], forgettings=[1.0, 0.99])
    ... # doctest: +NORMALIZE_WHITESPACE
    [{'method': 'algebraic', 'window': 0.05, 'forgetting': None},
     {'method': 'rls', 'window': None, 'forgetting': 1.0},
     {'method': 'rls', 'window': None, 'forgetting': 0.99}]
    """
    variants: list[dict] = []
    for method in methods:
        if method == "algebraic":
            for w in windows:
                check_positive(w, "window")
            variants += [
                {"method": "algebraic", "window": float(w), "forgetting": None} for w in windows
            ]
        elif method == "rls":
            for f in forgettings:
                if not 0 < float(f) <= 1:
                    raise InputError(f"{arg('forgetting')} must lie in (0, 1]; got {f!r}.")
            variants += [
                {"method": "rls", "window": None, "forgetting": float(f)} for f in forgettings
            ]
        else:
            raise InputError(
                f"{arg('method')} must be one of {list(LINEAR_ODE_METHODS)}; got {method!r}."
            )
    return variants


def make_estimator(settings: Mapping[str, Any], model):
    """The estimator a trial's settings ask for (``method``, ``window``, ``forgetting``, options).

    Parameters
    ----------
    settings : mapping
        ``method`` (``"algebraic"`` or ``"rls"``, default algebraic), ``window`` [s] (algebraic),
        ``forgetting`` (rls), ``estimator_options`` (further keyword settings).
    model : str or LinearODEModel
        The model the estimator fits.

    Returns
    -------
    estimator
        Unfitted, scikit-learn style (``fit(recording).result_``).
    """
    method = settings.get("method", "algebraic")
    options = dict(settings.get("estimator_options") or {})
    if method == "algebraic":
        options["window"] = float(settings.get("window") or 0.05)
    elif method == "rls":
        forgetting = settings.get("forgetting")
        options["forgetting"] = 1.0 if forgetting is None else float(forgetting)
        options.setdefault("covariance", "diagonal")  # a sweep needs θ̂ only: 4x less memory
    else:
        raise InputError(
            f"{arg('method')} must be one of {list(LINEAR_ODE_METHODS)}; got {method!r}."
        )
    try:
        from ..estimators.registry import make
    except ImportError:  # before the estimator registry: the two linear-ODE estimators
        make = None
    if make is not None:
        return make(method, model, **options)
    if method == "algebraic":
        from ..estimators.algebraic import AlgebraicEstimator

        return AlgebraicEstimator(model=model, **options)
    from ..estimators.recursive import RecursiveLeastSquares

    return RecursiveLeastSquares(model=model, **options)


def _estimates(result) -> dict[str, float]:
    values: dict[str, float] = {}
    for source in (getattr(result, "parameters", None), getattr(result, "derived", None)):
        for k, v in dict(source or {}).items():
            try:
                values[k] = float(v)
            except (TypeError, ValueError):
                continue
    return values


@dataclass(frozen=True)
class EstimationTrial:
    """A sweep trial: simulate with ``scenario``, fit an estimator, compare with the truth.

    Parameters
    ----------
    scenario : callable
        ``scenario(settings, seed) -> Recording``; picklable for process pools and Dask. Its
        ``truth()`` (or the record's ``metadata["truth"]``) gives the true values.
    model : str
        The model the estimator fits (a built-in name or a model file path).
    track : str
        The quantity whose convergence is timed (e.g. ``"natural_frequency"``); falls back to
        the first estimated name when the result has no history of it.
    outputs : sequence of str, optional
        Quantities to report, in column order; default every estimated and derived value.
    truths : sequence of str, optional
        Quantities that get a ``_true`` column; default those of ``outputs`` with a truth.
    aliases : mapping of str to str
        Column stem per quantity (the MSD study writes ``omega0`` for ``natural_frequency``).
    tolerance : float
        Relative tolerance of the convergence times (default 2 %).
    estimator : callable, optional
        ``estimator(settings, model) -> estimator``; default `make_estimator`.
    truth : callable, optional
        ``truth(recording, settings) -> dict`` of true values; default the scenario's
        ``truth()``, else the record's ``metadata["truth"]``.

    Notes
    -----
    Called as ``trial(settings, seed) -> dict``: ``NAME_true``/``NAME_final`` per quantity,
    ``final_error`` (relative error of the tracked quantity's final estimate), ``t_first_hit`` and
    ``t_settle`` [s] (NaN: not within tolerance by the end), ``valid_fraction``, and a
    ``status`` ``"estimator-failed"`` with the estimator's message when it did not succeed.
    """

    scenario: Callable
    model: str
    track: str = "natural_frequency"
    outputs: tuple[str, ...] | None = None
    truths: tuple[str, ...] | None = None
    aliases: Mapping[str, str] = field(default_factory=dict)
    tolerance: float = DEFAULT_TOLERANCE
    estimator: Callable | None = None
    truth: Callable | None = None

    @property
    def preload_modules(self) -> tuple[str, ...]:
        """Modules a fork server imports once for every worker."""
        return ("physid.simulate", "physid.estimators.algebraic", "physid.estimators.recursive")

    def _truth(self, rec, settings) -> dict[str, float]:
        if self.truth is not None:
            return dict(self.truth(rec, settings))
        truth_of = getattr(self.scenario, "truth", None)
        if callable(truth_of):
            return dict(truth_of())
        return dict((getattr(rec, "metadata", {}) or {}).get("truth", {}))

    def __call__(self, settings: Mapping[str, Any], seed: int) -> dict[str, Any]:
        rec = self.scenario(settings, seed)
        truth = self._truth(rec, settings)
        factory = self.estimator or make_estimator
        result = factory(settings, self.model).fit(rec).result_
        values = _estimates(result)
        names = list(self.outputs) if self.outputs is not None else list(values)
        with_truth = set(self.truths) if self.truths is not None else set(truth)
        out: dict[str, Any] = {}
        for name in names:
            stem = self.aliases.get(name, name)
            if name in with_truth:
                out[f"{stem}_true"] = float(truth.get(name, math.nan))
            out[f"{stem}_final"] = values.get(name, math.nan)
        track = self.track if self.track in values else (names[0] if names else self.track)
        true_value = float(truth.get(track, math.nan))
        final = values.get(track, math.nan)
        out["final_error"] = (
            abs(final - true_value) / abs(true_value)
            if math.isfinite(final) and math.isfinite(true_value) and true_value != 0
            else math.nan
        )
        try:
            t, trace, valid = estimate_trace(result, track)
            tol = float(settings.get("tolerance", self.tolerance))
            conv = convergence_times(t, trace, true_value, tol, valid=valid)
        except InputError:  # no per-time history of it: no convergence times
            conv = {"first_hit": math.nan, "settle": math.nan}
        out["t_first_hit"] = conv["first_hit"]
        out["t_settle"] = conv["settle"]
        out["valid_fraction"] = float(getattr(result, "valid_fraction", math.nan))
        if not getattr(result, "success", True):
            out["status"] = "estimator-failed"
            out["message"] = str(getattr(result, "message", ""))
        return out


def model_sweep(
    model: str,
    snr_db: Sequence[float | None] = (25.0, 50.0, 80.0),
    ratio: Sequence[float] = (0.5, 1.0, 2.0, 5.0, 10.0),
    *,
    trials: int = 10,
    methods: Sequence[str] = LINEAR_ODE_METHODS,
    windows: Sequence[float] = (0.05,),
    forgettings: Sequence[float] = (1.0,),
    duration: float = 5.0,
    dt: float = 1e-3,
    amplitude: float = 1.0,
    reference: float | None = None,
    track: str = "natural_frequency",
    seed: int = 0,
    scheduler: Any = "local",
    workers: int | None = None,
    chunksize: int | None = None,
    scheduler_timeout: float = 30.0,
    progress: bool = True,
) -> SweepResult:
    """Monte-Carlo study of any linear-ODE model: SNR × Z × estimator configuration × seeds.

    Every (SNR, Z, trial) simulates one record (`SineScenario`), shared by all estimator
    configurations (a paired comparison), and each configuration fits it (`EstimationTrial`).

    Parameters
    ----------
    model : str
        A built-in linear-ODE model name or the path of a linear-ODE model file.
    snr_db : sequence of float [dB]
        Signal-to-noise ratios (None = noise-free).
    ratio : sequence of float
        Input frequency ratios Z = ω1 / ω_ref (`reference_frequency`).
    trials : int
        Noise realisations per (SNR, Z).
    methods : sequence of {"algebraic", "rls"}
        The estimators to compare.
    windows : sequence of float [s]
        Algebraic window lengths.
    forgettings : sequence of float
        RLS forgetting factors λ in (0, 1].
    duration, dt : float [s]
        Record length and sample period.
    amplitude : float
        Input amplitude A (unit of the input).
    reference : float [rad/s], optional
        ω_ref; default |a_0|^(1/n) of the model.
    track : str
        Quantity whose convergence is timed (default the natural frequency; the first estimated
        parameter where the model has none).
    seed : int
        Root seed.
    scheduler, workers, chunksize, scheduler_timeout, progress
        See `physid.analysis.montecarlo.run_sweep`.

    Returns
    -------
    SweepResult
        One row per (SNR, Z, estimator, trial).
    """
    if not isinstance(model, str):
        raise InputError(
            f"{arg('model')} must be a built-in name or a model file path (it is sent to worker "
            f"processes); got {type(model).__name__}."
        )
    _load(model)  # refuse a bad model file here, not in every trial
    ratio_values = check_ratios(ratio)
    scenario = SineScenario(
        model, duration=duration, dt=dt, amplitude=amplitude, reference_frequency=reference
    )
    grid = {
        "snr_db": [None if s is None else float(s) for s in snr_db],
        "ratio": ratio_values,
        "estimator": estimator_variants(methods, windows=windows, forgettings=forgettings),
    }
    return run_estimator_sweep(
        EstimationTrial(scenario, model, track=track),
        grid,
        label=f"sweep {model}",
        trials=trials,
        seed=seed,
        scheduler=scheduler,
        workers=workers,
        chunksize=chunksize,
        scheduler_timeout=scheduler_timeout,
        progress=progress,
    )
