"""Test (c) of an IDIM result: the inverse-model torque residual judged against the colouring its
filters predict, noise on the measured positions, and the model.

The residual of an IDIM cross-test is ``e = W(q_m) β − τ_f`` on rows the parallel filter has
low-passed and decimated by ``nd``. Three explanations, checked in this order:

* **the filters** — white torque noise leaves the rows with the autocorrelation ``ρ_l`` of the
  zero-phase parallel filter sampled every ``nd`` samples
  (`physid.estimators.idim.decimation.decimated_noise_correlation`), known exactly. With rows
  dropped near rest the rows kept are joined end to end, so the expected sample autocorrelation
  at lag ``l`` is ``Σ_t m_t m_{t+l} ρ(i_{t+l} − i_t) / Σ_t m_t`` (``i`` the rows' indices in the
  decimated sequence, ``m`` the equations kept). The residual's autocorrelation minus that is
  tested against the 99 % band of a series with autocorrelation ``ρ`` (Bartlett's variance),
  with the same rule as `residual_analysis` (two lags outside, or one outside the Bonferroni
  band): passing, the residual is "consistent (correlation as the filter predicts)";
* **noise on the measured positions** (errors in variables through the regressor) — white
  position noise of at most ``σ_b = std(Δ²q_m) / √6`` per joint (what the positions' second
  difference allows) is propagated through the fit's own rows, ``(W(q_m + n) − W(q_m)) β``; the
  residual's autocorrelation is fitted as a mixture of the filter's and that prediction's (share
  ``w``), and the noise is named when it explains at least `EXPLAINED` of the departure from
  the filter's colouring (pooled over the joints that show one; `EXPLAINED_JOINT` on each) and
  the power it needs is at most
  `NOISE_BOUND_FACTOR`² times the predicted power at ``σ_b``;
* **the model** otherwise ("model misses dynamics"), with the numbers of both checks.

When that says "model" and the fit dropped equations next to speed reversals or at low speed
(``reversal_joints``; `physid.estimators._stiction.reversal_samples` marks both),
`set_aside_reversals` tests again without those equations of the joints where they stand out
(mean square residual more than `STAND_OUT` times the joint's other equations', the fit's own
rule). If the other equations are then explained (filter or position noise), the explanation
is **"reversal friction"**, not "consistent": the residual stands out in equations the fit
itself leaves out, and the model explains the others. There Fc·sign(q̇) of the filtered
velocity does not follow the friction torque (dry friction smeared by the filters, sticking, or
another friction law: Stribeck, asymmetric Coulomb). The verdict says what was compared, the
equations set aside, each joint's share of its residual power, that nothing is to change for
this fit, and the fix if the friction law differs (a friction model with a smooth or stiction
term); per joint equations and mean square ratios are in the evidence, which stays that of
every equation, the rest's under ``other_equations``.
If not, "model" stands and says that setting them aside does not change it. Measured on the
quickstart's held-out ``arm6`` record (σ_q = 1e-4 rad, no torque noise, the IDIM-WLS fit of
the fixed excitation of `tests/test_validate_quickstart_residual.py`, the same with any BLAS
thread count): the residual is 1.33 % of the torque's spread, the same with the true
parameters; position noise needs 5.7× the power its bound gives (3.5× allowed); the residual
stands out in 18 of its 462 equations, those next to reversals or at low speed (joint 5: 3, 58 %
of its residual power, 31× its other equations' mean square), and without them 2.8× does:
"reversal friction"; link
3's inertial parameters 5 or 20 % off stay "model".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .residual import BAND_Z, NOISE_BOUND_FACTOR, RESOLUTION, residual_analysis

__all__ = [
    "explain_inverse_residual",
    "set_aside_reversals",
    "expected_autocorrelation",
    "bartlett_band",
]

#: Lags of the filter's correlation ρ used for the expectation and Bartlett's variance.
RHO_LAGS = 64
#: Position noise is named when its prediction explains at least this fraction of the squared
#: departure of the failing joints' autocorrelations from the filter's colouring, pooled, and
#: `EXPLAINED_JOINT` on each. Measured on a 4 s arm6 run with the true parameters: white
#: position noise of 3e-5..1e-3 rad alone, pooled 0.64-0.82 (worst joint 0.34-0.59); link 3's
#: inertial parameters 5-20 % off, with or without that noise, pooled at most 0.22 (worst 0).
#: One record of band-limited noise scatters too much for a test lag by lag.
EXPLAINED = 0.5
EXPLAINED_JOINT = 0.25
#: A joint's reversal equations are set aside when their mean square residual is more than this
#: many times its other equations' (the rule the IDIM fit drops them by).
STAND_OUT = 2.0


def expected_autocorrelation(rho, index, kept, max_lag: int) -> np.ndarray:
    """Expected sample autocorrelation, lags 1..max_lag, of a series with correlation ``rho``
    observed on ``index`` (rows joined end to end) with the entries ``kept``.

    Parameters
    ----------
    rho : array_like, shape (L + 1,)
        Correlation at lags 0..L of the underlying series (0 beyond L).
    index : array_like of int, shape (n,)
        Positions of the rows used in the underlying sequence (increasing).
    kept : array_like of bool, shape (n,)
        Entries that carry the series (the others are zero).
    max_lag : int
        Largest lag.

    Returns
    -------
    ndarray, shape (max_lag,)
        ``Σ_t m_t m_{t+l} ρ(i_{t+l} − i_t) / Σ_t m_t`` at l = 1..max_lag.
    """
    rho = np.asarray(rho, dtype=float)
    idx = np.asarray(index, dtype=int)
    m = np.asarray(kept, dtype=float)
    total = float(m.sum())
    out = np.zeros(max_lag)
    if total <= 0:
        return out
    for lag in range(1, max_lag + 1):  # a loop over lags (25), each vectorised over rows
        gap = idx[lag:] - idx[:-lag]
        r = np.where(gap < rho.size, rho[np.minimum(gap, rho.size - 1)], 0.0)
        out[lag - 1] = float(np.sum(m[lag:] * m[:-lag] * r)) / total
    return out


def bartlett_band(rho, n: int, max_lag: int) -> np.ndarray:
    """Standard deviation of the sample autocorrelation at lags 1..max_lag of ``n`` samples of a
    series with correlation ``rho`` (Bartlett 1946).

    Parameters
    ----------
    rho : array_like, shape (L + 1,)
        Correlation at lags 0..L (ρ_0 = 1).
    n : int
        Number of samples.
    max_lag : int
        Largest lag.

    Returns
    -------
    ndarray, shape (max_lag,)
        ``√(Σ_j (ρ_j² + ρ_{j+k} ρ_{j−k} − 4 ρ_k ρ_j ρ_{j−k} + 2 ρ_j² ρ_k²) / n)``; ``1/√n`` for
        white noise.
    """
    r = np.asarray(rho, dtype=float)
    big = r.size - 1 + max_lag
    full = np.zeros(2 * big + 1)  # ρ at lags −big..big
    full[big : big + r.size] = r
    full[big - r.size + 1 : big + 1] = r[::-1]
    j = np.arange(-(r.size - 1), r.size)
    at = lambda lags: full[big + lags]  # noqa: E731
    out = np.empty(max_lag)
    for k in range(1, max_lag + 1):
        rk = at(np.array([k]))[0]
        terms = at(j) ** 2 + at(j + k) * at(j - k) - 4 * rk * at(j) * at(j - k)
        terms = terms + 2 * at(j) ** 2 * rk**2
        out[k - 1] = np.sqrt(max(float(terms.sum()), 1e-12) / n)
    return out


def _fails(deviation, sd, n_lags: int) -> tuple[bool, int]:
    """`residual_analysis`'s rule on standardised deviations: (fails, lags outside the band)."""
    from scipy.stats import norm

    z = np.abs(np.asarray(deviation)) / sd
    outside = int(np.count_nonzero(z > BAND_Z))
    return outside >= 2 or bool(np.any(z > norm.ppf(1.0 - 0.005 / n_lags))), outside


def _autocorrelation(e, max_lag: int) -> np.ndarray:
    """Biased sample autocorrelation of each column of ``e`` (centred) at lags 1..max_lag."""
    e = e - e.mean(axis=0)
    den = np.sum(e * e, axis=0)
    den = np.where(den > 0, den, 1.0)
    n = e.shape[0]
    return np.array([np.sum(e[k:] * e[: n - k], axis=0) / den for k in range(1, max_lag + 1)]).T


def explain_inverse_residual(
    result: dict[str, Any],
    residual,
    measured,
    *,
    nd: int,
    index,
    kept,
    position_noise=None,
) -> None:
    """Say which explanation the data support for an IDIM torque residual, with the numbers.

    See the module docstring for the three explanations and how each is decided. (Long: the
    three verdicts are written out where they are decided, as in `explain_residual`.)

    Parameters
    ----------
    result : dict
        `residual_analysis` of ``residual``; updated in place: ``verdict``, ``explanation``
        (``"none"``, ``"resolution"``, ``"filter"``, ``"input noise"``, ``"model"``) and
        ``evidence`` (the numbers); `set_aside_reversals` may then make a ``"model"``
        explanation ``"reversal friction"``.
    residual, measured : array_like, shape (n_rows, n_joints)
        ``τ̂ − τ_f`` and ``τ_f`` on the rows tested [N·m or N].
    nd : int
        The fit's decimation factor.
    index : array_like of int, shape (n_rows,)
        The rows' positions in the decimated sequence.
    kept : array_like of bool, shape (n_rows, n_joints)
        The equations kept (False: dropped near rest, zero on both sides).
    position_noise : callable, optional
        ``position_noise() -> (list of residual arrays like residual, σ_b per joint)``: the
        residual white position noise of the bound ``σ_b`` gives through the fit's rows.
    """
    from ...estimators.idim.decimation import decimated_noise_correlation

    e = np.asarray(residual, dtype=float)
    tau = np.asarray(measured, dtype=float)
    e = e[:, None] if e.ndim == 1 else e
    tau = tau[:, None] if tau.ndim == 1 else tau
    kept = np.broadcast_to(np.asarray(kept, dtype=bool).reshape(e.shape[0], -1), e.shape)
    n, max_lag = e.shape[0], (len(result["lags"]) - 1) // 2
    rel = float(np.linalg.norm(e) / max(np.linalg.norm(tau - tau.mean(axis=0)), 1e-300))
    rho = decimated_noise_correlation(int(nd), RHO_LAGS)
    evidence: dict[str, Any] = {"relative_residual": rel, "decimate": int(nd), "rho": rho[1:6]}
    result["evidence"] = evidence
    if not result["autocorrelation"]:  # untestable (NaN or constant): the verdict says why
        result["explanation"] = "none"
        return
    if rel < RESOLUTION:
        result["explanation"] = "resolution"
        result["verdict"] = (
            f"consistent: the torque residual is {rel:.2g} of the torque's spread (below "
            f"{RESOLUTION:g}, the resolution of the arithmetic), so its correlations are those "
            "of the numerical error, not evidence against the model"
        )
        return
    observed = _autocorrelation(e, max_lag)  # (n_joints, max_lag)
    expected = np.array([expected_autocorrelation(rho, index, kept[:, j], max_lag)
                         for j in range(e.shape[1])])  # fmt: skip
    sd = bartlett_band(rho, n, max_lag)
    tests = [_fails(observed[j] - expected[j], sd, max_lag) for j in range(e.shape[1])]
    outside = [o for _, o in tests]
    evidence["filter_lags_outside"] = outside
    evidence["filter_largest_deviation"] = float(np.max(np.abs(observed - expected)))
    evidence["band"] = float(BAND_Z * sd.max())
    if not any(f for f, _ in tests):
        result["explanation"] = "filter"
        result["verdict"] = (
            "consistent (correlation as the filter predicts): the torque residual's "
            f"autocorrelation departs from the colouring the parallel filter and decimation by "
            f"{int(nd)} give white torque noise (ρ₁ = {rho[1]:.3f}, ρ₂ = {rho[2]:.3f}) at "
            f"no more than {max(outside)} of {max_lag} lags outside the 99 % band "
            f"(± {evidence['band']:.3f}; largest departure "
            f"{evidence['filter_largest_deviation']:.3f}, no lag beyond the Bonferroni band); "
            "the model explains the data"
        )
        return
    failing = [j for j, (f, _) in enumerate(tests) if f]
    if position_noise is not None and _position_noise_fits(
        result, e, observed, expected, rho, position_noise, failing
    ):
        return
    result["explanation"] = "model"
    share = evidence.get("position_noise_share")
    eiv = (
        f"; noise on the measured positions (at most σ_q ≈ {evidence['position_noise_bound']:.2g}"
        f" rad, what their second difference allows) explains "
        f"{100 * max(evidence['position_noise_explained_pooled'], 0.0):.0f} % of it "
        f"({100 * max(evidence['position_noise_explained'], 0.0):.0f} % on the worst joint) "
        f"and needs {evidence['position_noise_power_ratio']:.2g}× the power that bound gives "
        f"(at most {evidence['position_noise_power_limit']:.2g}× would do)"
        if share is not None
        else ""
    )
    result["verdict"] = (
        "the model misses dynamics (or its parameter values are off): the torque residual's "
        "autocorrelation departs from the "
        f"colouring the filters predict (ρ₁ = {rho[1]:.3f} after decimation by {int(nd)}) at "
        f"up to {max(outside)} lags, by up to {evidence['filter_largest_deviation']:.3f} "
        f"(99 % band ± {evidence['band']:.3f}){eiv}"
    )


def _position_noise_fits(result, e, observed, expected, rho, position_noise, failing) -> bool:
    """Whether noise on the measured positions explains what the filter does not (see the
    module docstring); sets ``result``'s explanation and verdict when it does.

    Judged on the joints that fail the filter's test (``failing``): for each, the share ``w``
    of the prediction in the residual's autocorrelation (least squares, in [0, 1]), the part of
    the departure from the filter's colouring it explains (`EXPLAINED` pooled, `EXPLAINED_JOINT`
    each), and the power it needs against the power the bound gives.
    """
    evidence = result["evidence"]
    draws, sigma_b = position_noise()
    if not draws:
        return False
    n, max_lag = e.shape[0], observed.shape[1]
    power = np.mean([np.sum(d * d, axis=0) for d in draws], axis=0)  # per joint, at σ_b
    each = np.array([_autocorrelation(d, max(max_lag, min(RHO_LAGS, n // 2))) for d in draws])
    long = each.mean(axis=0)
    shape = long[:, :max_lag]
    shares, explained, ratios, limits = [], [], [], []
    pooled = [0.0, 0.0]
    for j in failing:
        departure, diff = observed[j] - expected[j], shape[j] - expected[j]
        den = float(diff @ diff)
        w = float(np.clip(departure @ diff / den, 0.0, 1.0)) if den > 0 else 0.0
        left = departure - w * diff
        explained.append(1.0 - float(left @ left) / max(float(departure @ departure), 1e-300))
        pooled[0] += float(left @ left)
        pooled[1] += float(departure @ departure)
        needed = w * float(np.sum((e[:, j] - e[:, j].mean()) ** 2))
        ratios.append(needed / power[j] if power[j] > 0 else np.inf)
        spread = np.sqrt(2.0 * (1.0 + 2.0 * float(np.sum(long[j] ** 2))) / n)
        limits.append(NOISE_BOUND_FACTOR**2 * (1.0 + BAND_Z * spread))
        shares.append(w)
    evidence["position_noise_bound"] = float(np.max(sigma_b))
    evidence["position_noise_share"] = float(np.min(shares))
    evidence["position_noise_explained"] = float(np.min(explained))
    evidence["position_noise_power_ratio"] = float(np.max(ratios))
    evidence["position_noise_power_limit"] = float(np.min(limits))
    evidence["position_noise_explained_pooled"] = 1.0 - pooled[0] / max(pooled[1], 1e-300)
    fits = (
        evidence["position_noise_explained_pooled"] >= EXPLAINED
        and min(explained) >= EXPLAINED_JOINT
        and all(r <= lim for r, lim in zip(ratios, limits, strict=True))
    )
    if not fits:
        return False
    result["explanation"] = "input noise"
    sigma = float(np.max(sigma_b) * np.sqrt(max(float(np.max(ratios)), 0.0)))
    evidence["position_noise_std"] = sigma
    result["verdict"] = (
        "consistent with the model once noise on the measured positions is counted (input "
        "noise, errors in variables through the regressor): the torque residual is not white "
        f"beyond the filters' colouring (ρ₁ = {rho[1]:.3f}), but white position noise of "
        f"σ_q ≈ {sigma:.2g} rad (the positions' second difference allows "
        f"{np.max(sigma_b):.2g}) propagated through the fit's rows explains "
        f"{100 * evidence['position_noise_explained_pooled']:.0f} % of that departure "
        f"(at least {100 * evidence['position_noise_explained']:.0f} % on each joint that shows "
        "it), with the power that noise gives. Reduce the position noise (encoder resolution, a lower cut-off) "
        "or use an errors-in-variables estimate (IDIM-IV); the model need not change"
    )
    return True


def set_aside_reversals(
    result: dict[str, Any],
    residual,
    measured,
    *,
    nd: int,
    index,
    kept,
    reversal,
    position_noise=None,
) -> dict[str, Any]:
    """Test (c) again without the equations next to speed reversals or at low speed where they
    stand out.

    Called when `explain_inverse_residual` said "model" on a fit that dropped its reversal
    equations (see the module docstring). A joint's equations marked in ``reversal`` are set
    aside when their mean square residual exceeds `STAND_OUT` times that of its other kept
    equations. If the other equations are then explained (filter colouring or position noise),
    the explanation is ``"reversal friction"``, never "consistent": the residual stands out where
    the fit itself leaves equations out, as dry friction smeared by the filters or a wrong
    friction law (Stribeck, asymmetric Coulomb) would make it. (Long: the two verdicts are
    written out where they are decided.)

    Parameters
    ----------
    result : dict
        The explained `residual_analysis` of ``residual`` on every kept equation; updated in
        place.
    residual, measured : array_like, shape (n_rows, n_joints)
        ``τ̂ − τ_f`` and ``τ_f`` on the rows tested [N·m or N].
    nd : int
        The fit's decimation factor.
    index : array_like of int, shape (n_rows,)
        The rows' positions in the decimated sequence.
    kept, reversal : array_like of bool, shape (n_rows, n_joints)
        The equations kept, and those next to speed reversals or at low speed of the fit's
        ``reversal_joints``.
    position_noise : callable, optional
        ``position_noise(kept) -> callable`` as `explain_inverse_residual`'s ``position_noise``
        for the equations ``kept``.

    Returns
    -------
    dict
        ``result``. Its evidence keeps the numbers of every equation (``relative_residual``,
        the filter's and position noise's) and gains ``reversals_set_aside`` (the equations next
        to reversals or at low speed set aside, per joint: equations, share of that joint's
        residual power, mean square ratio) and
        ``other_equations`` (the explanation and evidence without them). Its explanation becomes
        ``"reversal friction"`` when the other equations are explained, else stays ``"model"``.
    """
    e = np.asarray(residual, dtype=float)
    kept = np.asarray(kept, dtype=bool)
    rev = np.asarray(reversal, dtype=bool) & kept
    other = kept & ~rev
    sq = e * e
    n_rev, n_other = rev.sum(axis=0), other.sum(axis=0)
    ms_rev = np.where(n_rev > 0, np.sum(np.where(rev, sq, 0.0), axis=0) / np.maximum(n_rev, 1), 0)
    ms_other = np.sum(np.where(other, sq, 0.0), axis=0) / np.maximum(n_other, 1)
    ratio = ms_rev / np.where(ms_other > 0, ms_other, np.inf)
    joints = np.flatnonzero((n_rev > 0) & (ratio > STAND_OUT))
    if joints.size == 0:
        return result
    aside = np.zeros_like(rev)
    aside[:, joints] = rev[:, joints]
    power = np.sum(np.where(kept, sq, 0.0), axis=0)
    # per joint only: the joints' torques (and residuals) have different scales [N·m]
    info = {
        "joints": [int(j) + 1 for j in joints],
        "equations": int(aside.sum()),
        "of": int(kept.sum()),
        "equations_per_joint": [int(aside[:, j].sum()) for j in joints],
        "power_share_per_joint": [float(np.sum(sq[aside[:, j], j]) / max(power[j], 1e-300))
                                  for j in joints],
        "mean_square_ratio": [float(ratio[j]) for j in joints],
    }  # fmt: skip
    kept2 = kept & ~aside
    e2 = np.where(kept2, e, 0.0)
    second = residual_analysis(e2, max_lag=(len(result["lags"]) - 1) // 2)
    explain_inverse_residual(
        second, e2, measured, nd=nd, index=index, kept=kept2,
        position_noise=None if position_noise is None else position_noise(kept2),
    )  # fmt: skip
    evidence = result["evidence"]
    evidence["reversals_set_aside"] = info
    evidence["other_equations"] = {"explanation": second["explanation"], **second["evidence"]}
    # per joint, the share of its residual power only: "most" would overstate a 15 % share
    shares = ", ".join(
        f"joint {j} {100 * sh:.0f} %" for j, sh in zip(joints + 1, info["power_share_per_joint"],
                                                       strict=True)
    )  # fmt: skip
    # "18 of its 462 equations, those next to ...": the 462 are every kept equation, not the
    # ones next to reversals
    where = (
        f"{info['equations']} of its {info['of']} equations, those next to speed reversals or "
        "at low speed, which the fit itself leaves out (share of each joint's residual power: "
        f"{shares})"
    )
    if second["explanation"] in ("model", "none"):
        result["verdict"] += f"; setting aside {where}, does not change this"
        return result
    other_why = {
        "filter": "the filters' colouring of white torque noise",
        "input noise": "noise on the measured positions, σ_q ≈ "
        f"{second['evidence'].get('position_noise_std', float('nan')):.2g} rad",
        "resolution": "the resolution of the arithmetic",
    }[second["explanation"]]
    result["explanation"] = "reversal friction"
    result["verdict"] = (
        f"against the filters' colouring and position noise, the torque residual "
        f"({evidence['relative_residual']:.2g} of the torque's spread) stands out in {where}; "
        f"the model explains the others by {other_why}. Nothing to change for this fit; if the "
        "friction law differs (Stribeck, asymmetric Coulomb), use a friction model with a smooth "
        "or stiction term"
    )
    return result
