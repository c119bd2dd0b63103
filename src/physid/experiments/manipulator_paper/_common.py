"""Constants and helpers shared by the sections of the manipulator reproduction."""

from __future__ import annotations

import warnings

import numpy as np

from ...analysis.identifiability import IdentifiabilityWarning
from ...estimators.input_error import (
    ENERGY_FRACTION_WARN,
    BoundWarning,
    FilterWarning,
    InputErrorEstimator,
    linear_least_squares,
)
from ...filters import design_filter_bank

PAPER = "Cedro & Janecki"

#: The paper's printed result (section 5, output of FindMinimum).
PAPER_RESULT = {
    "J": 0.0223076,
    "parameters": {
        "m1": 49.5818,
        "m2": 25.0003,
        "m3": 15.0549,
        "m4": 4.96068,
        "l1": 0.407419,
        "l2": 0.799701,
        "l3": 0.599708,
        "l4": 0.200892,
    },
    "evaluations": 1450,
}
#: The paper's starting values (mo1..mo4, lo1..lo4).
PAPER_INITIAL = {
    "m1": 50.1,
    "m2": 25.1,
    "m3": 15.1,
    "m4": 5.1,
    "l1": 0.41,
    "l2": 0.79,
    "l3": 0.59,
    "l4": 0.19,
}
#: The paper's true parameters ("Parametry").
TRUTH = {"m1": 50.0, "m2": 25.0, "m3": 15.0, "m4": 5.0, "l1": 0.4, "l2": 0.8, "l3": 0.6, "l4": 0.2}
SEPARATE = ("m2", "m3", "m4", "l2", "l3", "l4")
COMBO = "m1*l1**2"
TRUE_COMBO = TRUTH["m1"] * TRUTH["l1"] ** 2

#: Section titles: each is the section's key in results.json (keep them stable).
TITLES = {
    "overview": "Manipulator: what the paper claims and what we measured",
    "simulation": "Manipulator: closed-loop simulation (Cedro & Janecki, section 4)",
    "identification": "Manipulator: input-error identification (section 5)",
    "identifiability": "Manipulator: identifiability — m1 and l1 enter only as m1·l1²",
    "filters": "Manipulator: filter choice and bias",
    "noise": "Manipulator: measurement noise (errors-in-variables)",
    "errata": "Manipulator: errata of the paper",
}
#: Which renderer of physid.report writes each section.
KEYS = {name: f"manipulator.{name}" for name in TITLES}


def say(progress, text: str) -> None:
    if progress is not None:
        progress(f"manipulator: {text}")


def fit(model, rec, *, initial=PAPER_INITIAL, **settings):
    """Fit with warnings captured; returns (result, whether a FilterWarning was raised).

    Unless told otherwise this uses the paper's derivative filters and, as the paper, ignores
    the noise on q (``noise="ignore"``; the library's default compensates it), to reproduce its
    numbers.
    """
    settings.setdefault("derivatives", "paper")
    settings.setdefault("noise", "ignore")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = InputErrorEstimator(model, **settings).fit(rec, initial=initial).result_
    expected = (FilterWarning, IdentifiabilityWarning, BoundWarning)  # in result.warnings
    unexpected = [w for w in caught if not issubclass(w.category, expected)]
    for w in unexpected:  # pass anything else on
        warnings.warn(w.message, w.category, stacklevel=2)
    return result, any(issubclass(w.category, FilterWarning) for w in caught)


def errors(params: dict, combo: float | None = None) -> dict[str, float]:
    """Relative errors [%] of the identifiable quantities."""
    out = {n: 100.0 * (params[n] / TRUTH[n] - 1.0) for n in SEPARATE}
    value = params["m1"] * params["l1"] ** 2 if combo is None else combo
    out[COMBO] = 100.0 * (value / TRUE_COMBO - 1.0)
    return out


def max_abs(errors: dict[str, float]) -> float:
    return max(abs(v) for v in errors.values())


def see(key: str) -> str:
    """Pointer from an erratum to the report section that holds its evidence."""
    return f" (Evidence in section '{TITLES[key]}'.)"


def filtr2_gain_error(rec, half_width: int, cutoff: float) -> dict[str, float]:
    """Largest relative pass-band error of the paper's Filtr2 against s²·Filtr over the motion.

    The motion's band is [0, Ω_motion] with Ω_motion the frequency below which a fraction
    1 − ENERGY_FRACTION_WARN of the energy of Δq lies (worst joint), the same energy measure as
    `filter_band_check`. Error: max over that band of |H2(Ω) / ((jΩ/Δ)² H0(Ω)) − 1|. Computed
    once and quoted by the identification and filter sections and by the errata.
    """
    q = rec.select(rec.channels("q"))
    power = np.abs(np.fft.rfft(np.diff(q, axis=0), axis=0)) ** 2
    omega = np.linspace(0.0, np.pi, power.shape[0])
    cumulative = np.cumsum(power, axis=0) / power.sum(axis=0)
    band = max(
        float(omega[np.searchsorted(cumulative[:, j], 1.0 - ENERGY_FRACTION_WARN)])
        for j in range(q.shape[1])
    )
    out = {"motion_band_rad_per_sample": band}
    grid = np.linspace(band / 4000, band, 4000)
    s2 = (1j * grid / rec.dt) ** 2
    for design in ("paper", "consistent"):
        f0, _, f2 = design_filter_bank(half_width, cutoff, rec.dt, design=design)
        ratio = f2.frequency_response(grid) / (s2 * f0.frequency_response(grid))
        out[design] = float(np.max(np.abs(ratio - 1.0)))
    return out


def rod_inertia_share(model, rec) -> float:
    """J1 = m1·l1²/12 over the mean of joint 1's total inertia M11(q) along the record."""
    q = rec.select(rec.channels("q"))[::50]
    m11 = np.asarray(model.mass_matrix(q, TRUTH), dtype=float)[:, 0, 0]
    return float(TRUE_COMBO / 12.0 / m11.mean())


class FastJ:
    """The paper's J through the linear-in-β form: J(θ) = |R (β(θ) − β̂)|² / N + J_min.

    τ̂ = Y β(θ); β̂ the least-squares solution of Y β = τ^f and R a small factor of Y
    (`linear_least_squares`). The same J as the residual form (the identification section
    compares both at the estimate), but each evaluation costs microseconds, which makes grids
    and a derivative-free search affordable.
    """

    def __init__(self, model, estimator: InputErrorEstimator, rec):
        _, qf, qdf, qddf, tau_f, _, _ = estimator.filtered_signals(rec)
        y = np.asarray(model.regressor(qf, qdf, qddf), dtype=float)
        y = y.reshape(-1, y.shape[-1])
        self.n = qf.shape[0]
        self.beta_hat, self.r = linear_least_squares(y, tau_f.ravel())
        self.j_min = float(np.sum((y @ self.beta_hat - tau_f.ravel()) ** 2)) / self.n
        self.model = model
        self.names = tuple(model.parameter_names)

    def __call__(self, theta) -> float:
        beta = np.asarray(
            self.model.beta(
                dict(zip(self.names, np.asarray(theta, dtype=float).tolist(), strict=True))
            )
        )
        d = self.r @ (beta - self.beta_hat)
        return float(d @ d) / self.n + self.j_min
