"""The Monte-Carlo study of Oueslati et al. (2011, section 5) on the generic sweep engine.

The paper's mass-spring-damper (`physid.simulate.msd_paper_scenario`: m = 3 kg, k = 400 N/m,
u = A1 sin(Z ω0 t), white noise at an SNR) is one *scenario*; the algebraic and the recursive
estimator are the *estimators* (`physid.analysis.studies.make_estimator`); an
`physid.analysis.studies.EstimationTrial` fits each to the same record and measures how fast ω0
reaches 2 %; `physid.analysis.montecarlo.run_sweep` runs the grid SNR × Z × estimator × seeds.
The columns keep the paper's names: ``omega0_true``/``omega0_final``, ``zeta_final``,
``theta1_*``, ``theta2_*``, ``final_error``, ``t_first_hit``, ``t_settle``, ``valid_fraction``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .._validate import check_positive
from ..models.linear_ode import MSD_NATURAL_FREQUENCY
from .studies import (
    TIME_COLUMNS,
    EstimationTrial,
    check_ratios,
    check_record_length,
    estimator_variants,
    make_estimator,
    run_estimator_sweep,
)
from .sweep_backends import parse_scheduler
from .sweep_table import SweepResult

__all__ = [
    "PaperMSDScenario",
    "paper_truth",
    "msd_trial",
    "msd_sweep",
    "msd_estimator_variants",
    "MSD_TIME_COLUMNS",
    "MSD_NATURAL_FREQUENCY",
]

#: Columns of the MSD table that are convergence times (NaN = not converged; medians are censored).
MSD_TIME_COLUMNS = TIME_COLUMNS
#: The quantities the study reports, in column order, and the column stems it writes for them.
_OUTPUTS = ("natural_frequency", "damping_ratio", "theta1", "theta2")
_TRUTHS = ("natural_frequency", "theta1", "theta2")
_ALIASES = {"natural_frequency": "omega0", "damping_ratio": "zeta"}


@dataclass(frozen=True)
class PaperMSDScenario:
    """The paper's MSD record for one trial: ``msd_paper_scenario(ratio, snr_db, seed=seed)``.

    Called as ``scenario(settings, seed)`` with ``settings["ratio"]`` (Z), ``["snr_db"]`` (None:
    clean) and optionally ``["duration"]`` [s] (default 5) and ``["dt"]`` [s] (1e-3). The truths
    (ω0, θ1, θ2) are in the record's metadata (`paper_truth`).
    """

    def __call__(self, settings: Mapping[str, Any], seed: int):
        from ..simulate import msd_paper_scenario

        rec = msd_paper_scenario(
            ratio=float(settings["ratio"]),
            snr_db=None if settings.get("snr_db") is None else float(settings["snr_db"]),
            duration=float(settings.get("duration", 5.0)),
            dt=float(settings.get("dt", 1e-3)),
            seed=int(seed),
        )
        return rec


def paper_truth(rec, settings=None) -> dict[str, float]:
    """ω0, θ1, θ2 of the record's system, from its metadata (ω0 defaults to the paper's).

    Parameters
    ----------
    rec : Recording
        A record of `PaperMSDScenario`.
    settings : mapping, optional
        The trial's settings (unused).

    Returns
    -------
    dict
        ``natural_frequency`` [rad/s], ``theta1`` [1/s], ``theta2`` [1/s²].
    """
    meta = getattr(rec, "metadata", {}) or {}
    out = {"natural_frequency": MSD_NATURAL_FREQUENCY}
    for key in ("natural_frequency", "omega0"):
        if key in meta and isinstance(meta[key], (int, float)):
            out["natural_frequency"] = float(meta[key])
            break
    for key in ("theta1", "theta2"):
        out[key] = float(meta.get(key, float("nan")))
    return out


_MSD_TRIAL = EstimationTrial(
    PaperMSDScenario(),
    "msd",
    track="natural_frequency",
    outputs=_OUTPUTS,
    truths=_TRUTHS,
    aliases=_ALIASES,
    truth=paper_truth,
)


def msd_trial(settings: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """One trial of the MSD study: simulate the paper's scenario, estimate ω0, measure convergence.

    Parameters
    ----------
    settings : mapping
        ``snr_db`` (None = noise-free), ``ratio`` (Z = ω1/ω0), ``method`` (``"algebraic"`` or
        ``"rls"``), ``window`` [s] (algebraic), ``forgetting`` (rls), and optionally ``duration``
        [s] (default 5), ``dt`` [s] (1e-3), ``tolerance`` (0.02), ``estimator_options`` (dict
        passed to the estimator).
    seed : int
        Seed of the measurement noise.

    Returns
    -------
    dict
        ``omega0_true``, ``omega0_final``, ``zeta_final``, ``theta1_true``, ``theta1_final``,
        ``theta2_true``, ``theta2_final`` (the truths and the estimator's final estimates; the
        ``*_final`` / ``*_true`` pairs give the bias and spread in `SweepResult.summarize`),
        ``final_error`` (relative ω0 error of the final estimate), ``t_first_hit`` and ``t_settle``
        [s] (`physid.analysis.metrics`; NaN = not within 2 % by the end), ``valid_fraction``, and a
        ``status`` ``"estimator-failed"`` with the estimator's message when it did not succeed.
    """
    return _MSD_TRIAL(settings, seed)


msd_trial.preload_modules = _MSD_TRIAL.preload_modules  # type: ignore[attr-defined]


#: Estimator configurations for the MSD sweep: the same as every linear-ODE sweep's
#: (`physid.analysis.studies.estimator_variants`; the MSD name is kept for its callers).
msd_estimator_variants = estimator_variants


def _warm_up(variants: Sequence[Mapping[str, Any]]) -> None:
    """Run each estimator configuration once on a short clean record (fills in-memory caches).

    The record is 600 samples at the sweep's own sample period, so a coarse ``dt`` never makes
    the warm-up complain about a duration the user did not give; failures are left for the real
    trials to report.
    """
    from ..simulate import msd_paper_scenario

    dt = float(variants[0].get("dt", 1e-3))
    try:
        rec = msd_paper_scenario(ratio=10.0, duration=600 * dt, dt=dt)
    except Exception:  # noqa: BLE001 - the real trials report the problem with its message
        return
    for settings in variants:
        try:
            make_estimator(settings, "msd").fit(rec)
        except Exception:  # noqa: S112, BLE001 - the real trials report it with its message
            continue


def msd_sweep(
    snr_db: Sequence[float | None] = (25.0, 50.0, 80.0),
    ratio: Sequence[float] = (0.5, 1.0, 2.0, 5.0, 10.0),
    *,
    trials: int = 10,
    methods: Sequence[str] = ("algebraic", "rls"),
    windows: Sequence[float] = (0.05,),
    forgettings: Sequence[float] = (1.0,),
    duration: float = 5.0,
    dt: float = 1e-3,
    seed: int = 0,
    scheduler: Any = "local",
    workers: int | None = None,
    chunksize: int | None = None,
    progress: bool = True,
    estimator_options: Mapping[str, Mapping[str, Any]] | None = None,
    scheduler_timeout: float = 30.0,
) -> SweepResult:
    """The convergence study of Oueslati et al. (2011, Figs. 5–6): SNR × Z × estimator × seeds.

    Every (SNR, Z, trial) simulates one noisy record of the paper's MSD (`PaperMSDScenario`),
    shared by all estimator configurations (paired comparison), and each configuration estimates
    ω0 on it (`msd_trial`).

    Parameters
    ----------
    snr_db, ratio, trials, methods, windows, forgettings, duration, dt, seed
        As in `physid.analysis.studies.model_sweep` (SNR [dB], Z = ω1 / ω0, noise realisations
        per (SNR, Z), the estimators, algebraic windows [s], RLS forgetting factors, record
        length and sample period [s], root seed).
    scheduler, workers, chunksize, progress, scheduler_timeout
        See `physid.analysis.montecarlo.run_sweep`.
    estimator_options : mapping, optional
        ``{"algebraic": {...}, "rls": {...}}`` extra keyword arguments per method.

    Returns
    -------
    SweepResult
        One row per (SNR, Z, estimator, trial).
    """
    snr_values = [None if s is None else float(s) for s in snr_db]
    ratio_values = check_ratios(ratio)
    duration = check_positive(duration, "duration")
    dt = check_positive(dt, "dt")
    check_record_length(duration, dt)
    variants = estimator_variants(methods, windows=windows, forgettings=forgettings)
    options = dict(estimator_options or {})
    for v in variants:
        v["duration"] = duration
        v["dt"] = dt
        if options.get(v["method"]):
            v["estimator_options"] = dict(options[v["method"]])
    grid = {"snr_db": snr_values, "ratio": ratio_values, "estimator": variants}
    kind, _ = parse_scheduler(scheduler)
    if kind == "local":
        _warm_up(variants)  # derive the estimators' kernels once here; forked workers inherit them
    return run_estimator_sweep(
        msd_trial,
        grid,
        label="sweep msd",
        censored_columns=MSD_TIME_COLUMNS,
        trials=trials,
        seed=seed,
        scheduler=scheduler,
        workers=workers,
        chunksize=chunksize,
        scheduler_timeout=scheduler_timeout,
        progress=progress,
    )
