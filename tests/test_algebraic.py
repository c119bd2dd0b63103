"""Tests of the algebraic (Fliess / Sira-Ramírez) sliding-window estimator.

Noise-free data come from the exact solution of the linear ODE driven by sinusoids: the ODE and
the sinusoid generators form one autonomous linear system ż = F z, solved in closed form through
the eigen-decomposition of F (checked against scipy's DOP853 at rtol 1e-12 below).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from physid.errors import EstimationError, InputError, SamplingError, ShapeError
from physid.estimators.algebraic import (
    AlgebraicEstimator,
    AlgebraicResult,
    StreamingAlgebraicEstimator,
    algebraic_estimates,
    algebraic_kernels,
    quadrature_taps,
)
from physid.models.linear_ode import LinearODEModel, msd_model
from physid.signals.recording import Recording

DT = 1e-3
OMEGA0 = math.sqrt(400.0 / 3.0)  # the paper's k = 400 N/m, m = 3 kg [rad/s]


def ode_model(order, input_order, unknown=None, parameters=None):
    a = tuple(f"a{i}" for i in range(order))
    b = tuple(f"b{i}" for i in range(input_order + 1))
    values = {k: 1.0 for k in a + b}
    values.update(parameters or {})
    return LinearODEModel(f"order{order}", a, b, values, unknown=unknown, output_name="y")


def simulate_exact(a, b, t, sines, x0=None):
    """u, y of Σ a_i y^(i) = Σ b_i u^(i) (a[-1] = 1) with u = Σ A sin(ω t + φ), exact.

    Controllable canonical form (y = Σ b_i z_{i}) augmented with one oscillator per sinusoid.
    """
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    n = a.size - 1
    nz = n + 2 * len(sines)
    F = np.zeros((nz, nz))
    F[: n - 1, 1:n] = np.eye(n - 1)
    F[n - 1, :n] = -a[:n]
    z0 = np.zeros(nz)
    if x0 is not None:
        z0[:n] = x0
    for k, (amp, w, ph) in enumerate(sines):
        j = n + 2 * k
        F[j, j + 1] = w
        F[j + 1, j] = -w
        F[n - 1, j] += amp
        z0[j], z0[j + 1] = np.sin(ph), np.cos(ph)
    lam, V = np.linalg.eig(F)
    c = np.linalg.solve(V, z0.astype(complex))
    Z = ((np.exp(np.outer(t, lam)) * c) @ V.T).real
    # at t = 0 the state is z0 by definition; the eigenvector round trip leaves ~1e-18 there,
    # which would make a system at rest look excited
    Z[t == 0.0] = z0
    C = np.zeros(nz)
    C[: b.size] = b
    u = np.zeros_like(t) + sum(amp * np.sin(w * t + ph) for amp, w, ph in sines)
    return u, Z @ C


def msd_signals(zeta=0.3, duration=1.0, ratio=10.0, x0=(0.01, 0.2)):
    t = np.arange(0.0, duration, DT)
    th1, th2 = 2 * zeta * OMEGA0, OMEGA0**2
    u, y = simulate_exact([th2, th1, 1.0], [1.0], t, [(1000.0 / 3.0, ratio * OMEGA0, 0.0)], x0=x0)
    return t, u, y, th1, th2


def test_exact_simulator_matches_dop853():
    t = np.linspace(0, 2, 2001)
    u, y = simulate_exact([5.0, 2.0, 1.0], [1.0], t, [(3.0, 7.0, 0.2)], x0=[0.1, -0.3])
    sol = solve_ivp(
        lambda tt, x: [x[1], -5 * x[0] - 2 * x[1] + 3 * np.sin(7 * tt + 0.2)],
        (0, 2),
        [0.1, -0.3],
        t_eval=t,
        rtol=1e-12,
        atol=1e-14,
        method="DOP853",
    )
    assert np.max(np.abs(sol.y[0] - y)) < 1e-10


# ------------------------------------------------------------------------------ derivation
@pytest.mark.parametrize(
    "order,N,nu", [(1, 1, 2), (2, 2, 3), (2, 2, 5), (2, 4, 3), (3, 3, 4), (3, 4, 6)]
)
def test_laplace_kernels_equal_modulating_functions(order, N, nu):
    """The Laplace route equals integration by parts against φ = (1−σ)^(ν−1)(−σ)^N/(ν−1)!."""
    sigma = sp.Symbol("sigma")
    (row,) = algebraic_kernels(order, (nu,), N)
    phi = (1 - sigma) ** (nu - 1) * (-sigma) ** N / sp.factorial(nu - 1)
    for i, k in enumerate(row):
        assert sp.expand(k - (-1) ** i * sp.diff(phi, sigma, i)) == 0


def test_kernels_reproduce_corrected_eq20_entries():
    """MSD, ν = μ: θ1 column = 2P_{μ,1} + P_{μ−1,2}, θ2 column = P_{μ,2} (paper's P, T = 1)."""
    sigma = sp.Symbol("sigma")

    def P(m, n):  # kernel of the paper's P_{m,n} in forward time, T = 1
        return (1 - sigma) ** (m - 1) * (-sigma) ** n / sp.factorial(m - 1)

    for mu in (3, 4, 6):
        rows = algebraic_kernels(2, (mu, mu + 1))
        for r, nu in enumerate((mu, mu + 1)):
            k0, k1, k2 = rows[r]
            assert sp.expand(k1 - (2 * P(nu, 1) + P(nu - 1, 2))) == 0
            assert sp.expand(k0 - P(nu, 2)) == 0
            assert sp.expand(k2 - (2 * P(nu, 0) + 4 * P(nu - 1, 1) + P(nu - 2, 2))) == 0
        # the printed (2,1) entry 2P_{μ+1,0} + P_{μ,1} is not the derived one
        assert sp.expand(rows[1][1] - (2 * P(mu + 1, 0) + P(mu, 1))) != 0


def test_mu_below_order_plus_one_rejected():
    with pytest.raises(InputError, match="order \\+ 1"):
        algebraic_kernels(2, (2,))


# ------------------------------------------------------------------------------ quadrature
def test_exact_rule_is_exact_on_interpolated_polynomials():
    rng = np.random.default_rng(1)
    kern = rng.standard_normal(6)  # degree-5 kernel
    for d in (3, 5, 7):
        g = rng.standard_normal(d + 1)  # degree-d signal: the local interpolant reproduces it
        L = 13
        s = np.linspace(0, 1, L + 1)
        taps = quadrature_taps(kern, L, "exact", d)
        exact = np.polynomial.polynomial.Polynomial(
            np.polynomial.polynomial.polymul(kern, g)
        ).integ()
        assert taps @ np.polynomial.polynomial.polyval(s, g) == pytest.approx(
            exact(1) - exact(0), rel=1e-12
        )


@pytest.mark.parametrize(
    "rule,degree,slope", [("exact", 3, 4), ("exact", 5, 6), ("simpson", 0, 4), ("trapezoid", 0, 2)]
)
def test_quadrature_convergence_order(rule, degree, slope):
    kern = np.array([0.0, 1.0, -3.0, 2.0])  # σ(1−σ)(1−2σ)
    f = lambda s: np.cos(3 * s + 0.4)  # noqa: E731
    sigma = sp.Symbol("sigma")
    ref = float(
        sp.integrate(
            (sigma - 3 * sigma**2 + 2 * sigma**3) * sp.cos(3 * sigma + sp.Rational(2, 5)),
            (sigma, 0, 1),
        )
    )
    Ls = np.array([16, 32, 64])
    err = [
        abs(quadrature_taps(kern, L, rule, max(degree, 1)) @ f(np.linspace(0, 1, L + 1)) - ref)
        for L in Ls
    ]
    fitted = -np.polyfit(np.log(Ls), np.log(err), 1)[0]
    assert fitted == pytest.approx(slope, abs=0.35)


# ------------------------------------------------------------------------------ accuracy
def test_msd_noise_free_exact_rule_within_1e6():
    t, u, y, th1, th2 = msd_signals(zeta=0.3)
    res = algebraic_estimates(u, y, DT, msd_model(), window=0.05)
    assert res.success
    assert res.parameters["theta1"] == pytest.approx(th1, rel=1e-6)
    assert res.parameters["theta2"] == pytest.approx(th2, rel=1e-6)
    assert res.derived["natural_frequency"] == pytest.approx(OMEGA0, rel=1e-6)
    assert res.derived["damping_ratio"] == pytest.approx(0.3, rel=1e-6)
    # every valid window, not just the median
    est = res.estimates[res.valid]
    assert np.max(np.abs(est / [th1, th2] - 1)) < 1e-6
    # causal: no estimate before the first full window
    assert not res.valid[:50].any() and np.isnan(res.estimates[:50]).all()
    assert res.valid_fraction > 0.8


def test_simpson_and_trapezoid_are_coarser_than_exact():
    t, u, y, th1, th2 = msd_signals(zeta=0.3)
    errs = {}
    for rule in ("exact", "simpson", "trapezoid"):
        res = algebraic_estimates(u, y, DT, msd_model(), window=0.05, integration=rule)
        per_window = res.series("theta2")[res.valid]  # the rule's error shows window by window
        errs[rule] = np.max(np.abs(per_window / th2 - 1))
    assert errs["exact"] < 1e-6 < errs["simpson"] < errs["trapezoid"]


def test_third_order_model_recovers_all_coefficients():
    # y''' + a2 y'' + a1 y' + a0 y = b0 u + b1 u'; poles -2, -3 ± 4j; zero at -b0/b1
    a = np.real(np.poly([-2.0, -3 + 4j, -3 - 4j]))[::-1]  # ascending a0, a1, a2, 1
    b = [20.0, 4.0]
    t = np.arange(0.0, 1.5, DT)
    sines = [(30.0, 5.0, 0.0), (20.0, 13.0, 1.0), (10.0, 31.0, 2.0)]
    u, y = simulate_exact(a, b, t, sines, x0=[0.1, -0.2, 0.3])
    model = ode_model(3, 1)
    res = algebraic_estimates(u, y, DT, model, window=0.4)
    truth = dict(zip(("a0", "a1", "a2", "b0", "b1"), [*a[:3], *b], strict=True))
    for name, value in truth.items():
        assert res.parameters[name] == pytest.approx(value, rel=1e-6), name
    # with a2 and b1 known, the rest is still recovered
    res2 = algebraic_estimates(
        u, y, DT, model, window=0.4, unknown=("a0", "a1", "b0"), known={"a2": a[2], "b1": b[1]}
    )
    for name in ("a0", "a1", "b0"):
        assert res2.parameters[name] == pytest.approx(truth[name], rel=1e-6), name


def test_known_coefficients_move_to_the_right_hand_side():
    t, u, y, th1, th2 = msd_signals(zeta=0.3)
    res = algebraic_estimates(
        u, y, DT, msd_model(), window=0.05, unknown=("theta2",), known={"theta1": th1}
    )
    assert res.names == ("theta2",)
    assert res.parameters["theta2"] == pytest.approx(th2, rel=1e-6)
    assert res.derived["natural_frequency"] == pytest.approx(OMEGA0, rel=1e-6)
    # the input gain as a third unknown
    res3 = algebraic_estimates(
        2.5 * u, y, DT, msd_model(), window=0.05, unknown=("theta1", "theta2", "b0")
    )
    assert res3.parameters["b0"] == pytest.approx(0.4, rel=1e-6)
    assert res3.parameters["theta1"] == pytest.approx(th1, rel=1e-6)


def test_free_response_without_input():
    """u ≡ 0, x(0) ≠ 0: the damped oscillation alone determines θ1 and θ2 (b0 known)."""
    t = np.arange(0.0, 1.0, DT)
    th1, th2 = 2 * 0.3 * OMEGA0, OMEGA0**2
    u, y = simulate_exact([th2, th1, 1.0], [1.0], t, [], x0=[0.05, 1.0])
    assert not np.any(u)
    res = algebraic_estimates(u, y, DT, msd_model(), window=0.1)
    assert res.parameters["theta1"] == pytest.approx(th1, rel=1e-6)
    assert res.parameters["theta2"] == pytest.approx(th2, rel=1e-6)


def test_initial_conditions_are_annihilated():
    """The estimate does not depend on the (unknown) initial state."""
    for x0 in [(0.0, 0.0), (1.0, -30.0)]:
        t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=0.3, x0=x0)
        res = algebraic_estimates(u, y, DT, msd_model(), window=0.05)
        assert np.max(np.abs(res.estimates[res.valid] / [th1, th2] - 1)) < 1e-6


# ------------------------------------------------------------------------------ the paper's eq. 20
def _paper_P(m, n, g, e, L, T, reverse):
    """Paper eq. 18: (−1)^n T^(m+n)/(m−1)! ∫_0^1 (1−τ)^(m−1) τ^n γ(t0 − τT) dτ, t0 = sample e.

    ``reverse=True`` is the printed kernel (samples run backwards from t0); ``False`` is ours."""
    P = np.polynomial.polynomial
    poly = P.polymul(P.polypow([1.0, -1.0], m - 1), np.eye(n + 1)[n])
    w = quadrature_taps(poly, L, "exact")
    seg = g[e - L : e + 1]
    return (-1) ** n * T ** (m + n) / math.factorial(m - 1) * (w @ (seg[::-1] if reverse else seg))


def _paper_eq20(u, x, e, L, T, mu=3, reverse=True, printed=True):
    def Px(m, n):
        return _paper_P(m, n, x, e, L, T, reverse)

    def Pu(m, n):
        return _paper_P(m, n, u, e, L, T, reverse)

    a21 = 2 * Px(mu + 1, 0) + Px(mu, 1) if printed else 2 * Px(mu + 1, 1) + Px(mu, 2)
    A = np.array([[2 * Px(mu, 1) + Px(mu - 1, 2), Px(mu, 2)], [a21, Px(mu + 1, 2)]])
    r = np.array(
        [
            -2 * Px(mu, 0) - 4 * Px(mu - 1, 1) - Px(mu - 2, 2) + Pu(mu, 2),
            -2 * Px(mu + 1, 0) - 4 * Px(mu, 1) - Px(mu - 1, 2) + Pu(mu + 1, 2),
        ]
    )
    return np.linalg.solve(A, r)


def test_printed_eq20_gives_the_wrong_answer_on_a_damped_msd():
    """Why we differ from the paper.

    On ζ = 0.3 the literal eq. 20 with the eq. 17-18 kernel misses θ1 by ~100 % and θ2 by > 10 %.
    Fixing only entry (2,1) still returns −θ1: the backward kernel estimates the time-reversed
    system. Both fixes together (what `algebraic_estimates` does) give the true values. On the
    paper's own system (ζ ≈ 7e-4) the printed form's ω0 error is small, which hid the errors.
    """
    L, T = 50, 0.05
    t, u, y, th1, th2 = msd_signals(zeta=0.3)
    ends = range(200, 900, 37)
    printed = np.median([_paper_eq20(u, y, e, L, T) for e in ends], axis=0)
    assert abs(printed[0] - th1) > 0.9 * th1
    assert abs(printed[1] / th2 - 1) > 0.1
    reversed_only = np.median([_paper_eq20(u, y, e, L, T, printed=False) for e in ends], axis=0)
    assert reversed_only[0] == pytest.approx(-th1, rel=1e-6)  # time-reversed system
    assert reversed_only[1] == pytest.approx(th2, rel=1e-6)
    fixed = np.median(
        [_paper_eq20(u, y, e, L, T, reverse=False, printed=False) for e in ends], axis=0
    )
    assert fixed == pytest.approx([th1, th2], rel=1e-6)
    ours = algebraic_estimates(u, y, DT, msd_model(), window=T)
    assert ours.estimates[list(ends)] == pytest.approx(
        np.tile([th1, th2], (len(ends), 1)), rel=1e-6
    )
    # the paper's system hides it: ζ = 0.05 / (2 √(400·3)) ≈ 7.2e-4
    zeta_paper = 0.05 / (2 * math.sqrt(400 * 3))
    t, u, y, th1, th2 = msd_signals(zeta=zeta_paper)
    printed = np.median([_paper_eq20(u, y, e, L, T) for e in ends], axis=0)
    assert abs(math.sqrt(printed[1]) / OMEGA0 - 1) < 2e-3


# ---------------------------------------------------------------------- batch vs literal loop
def _literal_taps(order, N, nus, L, rule):
    """Kernels from the modulating-function form with numpy (independent of sympy), and the
    quadrature weights written out: Simpson's h/3 [1 4 2 4 … 4 1], or the shared 'exact' taps."""
    P = np.polynomial.polynomial
    out = np.empty((len(nus), order + 1, L + 1))
    s = np.linspace(0.0, 1.0, L + 1)
    for r, nu in enumerate(nus):
        phi = P.polymul(P.polypow([1.0, -1.0], nu - 1), P.polypow([0.0, -1.0], N)) / math.factorial(
            nu - 1
        )
        kn = P.polyder(phi, order) * (-1) ** order
        norm = math.sqrt(P.polyval(1.0, P.polyint(P.polymul(kn, kn))))
        for i in range(order + 1):
            k = (P.polyder(phi, i) if i else phi) * (-1) ** i / norm
            if rule == "simpson":
                w = np.full(L + 1, 2.0)
                w[1::2] = 4.0
                w[0] = w[-1] = 1.0
                out[r, i] = P.polyval(s, k) * w / (3 * L)
            else:
                out[r, i] = quadrature_taps(k, L, "exact")
    return out


def _literal_loop(
    u,
    y,
    dt,
    a_unknown,
    b_unknown,
    known_a,
    known_b,
    order,
    window,
    rule="exact",
    mu=None,
    N=None,
    n_eq=None,
    block=1,
    stride=1,
):
    """One window at a time: weights × samples, assemble, solve (lstsq for blocks)."""
    L = int(round(window / dt))
    T = L * dt
    p = len(a_unknown) + len(b_unknown)
    mu = order + 1 if mu is None else mu
    N = order if N is None else N
    nus = tuple(range(mu, mu + (n_eq or p)))
    taps = _literal_taps(order, N, nus, L, rule)
    out = np.full((u.size, p), np.nan)
    for e in range(L, u.size):
        rows, rhs = [], []
        for j in range(block):
            ee = e - j * stride
            if ee < L:  # block members before the first full window do not exist
                continue
            ys, us = y[ee - L : ee + 1], u[ee - L : ee + 1]
            for r in range(len(nus)):
                Iy = [taps[r, i] @ ys for i in range(order + 1)]
                Iu = [taps[r, i] @ us for i in range(order + 1)]
                row = [Iy[i] * T ** (order - i) for i in a_unknown] + [
                    -Iu[i] * T ** (order - i) for i in b_unknown
                ]
                val = -Iy[order] - sum(v * Iy[i] * T ** (order - i) for i, v in known_a.items())
                val += sum(v * Iu[i] * T ** (order - i) for i, v in known_b.items())
                rows.append(row)
                rhs.append(val)
        out[e] = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    return out


@pytest.mark.parametrize(
    "rule,settings",
    [
        ("exact", {}),
        ("simpson", {}),
        ("exact", {"block": 3, "block_stride": 5}),
        ("exact", {"n_equations": 4, "mu": 4, "extra_derivatives": 1}),
    ],
)
def test_batch_equals_literal_per_window_loop(rule, settings):
    t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=0.4)
    rng = np.random.default_rng(3)
    y = y + 1e-4 * rng.standard_normal(y.size)  # noise, so that agreement is not trivial
    res = algebraic_estimates(
        u, y, DT, msd_model(), window=0.05, integration=rule, guard=0, **settings
    )
    ref = _literal_loop(
        u,
        y,
        DT,
        a_unknown=(1, 0),
        b_unknown=(),
        known_a={},
        known_b={0: 1.0},
        order=2,
        window=0.05,
        rule=rule,
        mu=settings.get("mu"),
        N=2 + settings.get("extra_derivatives", 0),
        n_eq=settings.get("n_equations"),
        block=settings.get("block", 1),
        stride=settings.get("block_stride", 1),
    )
    both = np.isfinite(ref).all(axis=1)
    assert np.array_equal(both, np.isfinite(res.estimates).all(axis=1))
    # rounding differences are amplified by cond(A); compare where the guard accepts the window
    guarded = algebraic_estimates(u, y, DT, msd_model(), window=0.05, integration=rule, **settings)
    np.testing.assert_array_equal(guarded.estimates, res.estimates)
    ok = guarded.valid
    assert ok.sum() > 0.8 * both.sum()
    # 2e-9: the two least-squares paths sum in different orders; with numpy 2.4 / OpenBLAS the
    # 4-equation, mu = 4 case differs by 1.07e-9 (2e-12 to 1.2e-11 in the others)
    assert np.max(np.abs(res.estimates[ok] / ref[ok] - 1)) < 2e-9


def test_batch_equals_literal_loop_third_order_with_known():
    a = np.real(np.poly([-2.0, -3 + 4j, -3 - 4j]))[::-1]
    t = np.arange(0.0, 1.2, DT)
    u, y = simulate_exact(
        a, [20.0, 4.0], t, [(30.0, 5.0, 0.0), (20.0, 13.0, 1.0), (10.0, 31.0, 2.0)]
    )
    model = ode_model(3, 1)
    res = algebraic_estimates(
        u, y, DT, model, window=0.3, unknown=("a0", "a2", "b1"), known={"a1": a[1], "b0": 20.0}
    )
    ref = _literal_loop(
        u,
        y,
        DT,
        a_unknown=(0, 2),
        b_unknown=(1,),
        known_a={1: a[1]},
        known_b={0: 20.0},
        order=3,
        window=0.3,
    )
    # the 3×3 systems are less well conditioned than the MSD's: 1e-8 on the valid windows
    assert res.valid.sum() > 800
    assert np.max(np.abs(res.estimates[res.valid] / ref[res.valid] - 1)) < 1e-8


# ------------------------------------------------------------------------------ streaming
@pytest.mark.parametrize(
    "settings",
    [
        {},
        {"block": 4, "block_stride": 3},
        {"expanding": True},
        {"expanding": True, "block": 2, "n_equations": 3},
    ],
)
def test_streaming_chunks_equal_batch(settings):
    t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=0.6)
    y = y + 1e-4 * np.random.default_rng(5).standard_normal(y.size)
    batch = algebraic_estimates(u, y, DT, msd_model(), window=0.05, **settings)
    stream = StreamingAlgebraicEstimator(msd_model(), dt=DT, window=0.05, **settings)
    cuts = np.sort(np.random.default_rng(7).choice(np.arange(1, u.size), 25, replace=False))
    cuts = np.concatenate([[0], [1, 2, 3], cuts[cuts > 3], [u.size]])
    est, valid, times = [], [], []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        upd = stream.update(u[a:b], y[a:b])
        est.append(upd.estimates)
        valid.append(upd.valid)
        times.append(upd.t)
    est = np.concatenate(est)
    np.testing.assert_array_equal(np.isnan(est), np.isnan(batch.estimates))
    ok = ~np.isnan(est)
    assert np.max(np.abs(est[ok] - batch.estimates[ok]) / np.abs(batch.estimates[ok])) <= 1e-10
    np.testing.assert_array_equal(np.concatenate(valid), batch.valid)
    np.testing.assert_allclose(np.concatenate(times), batch.t, rtol=0, atol=1e-12)
    # constant memory: the buffer never exceeds L + (block − 1) stride samples
    assert stream._u.size <= 50 + (settings.get("block", 1) - 1) * settings.get("block_stride", 1)


def test_expanding_window_estimates_before_t_equals_T():
    t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=0.3)
    res = algebraic_estimates(u, y, DT, msd_model(), window=0.05, expanding=True)
    early = res.estimates[20:50]  # windows [0, t0] of 20..49 samples
    assert np.isfinite(early).all()
    assert np.max(np.abs(early / [th1, th2] - 1)) < 1e-4
    assert np.isnan(res.estimates[:7]).all()  # fewer samples than the exact rule needs


# ------------------------------------------------------------------------------ robustness
def test_guard_marks_windows_near_zero_determinant():
    """At rest (u = 0, zero state) every window integral is 0, so det = 0 and the window is
    invalid. In motion the determinant of the sinusoidally driven MSD oscillates and dips towards
    zero; the guard rejects exactly the windows whose level falls below 0.1 × the running median."""
    t = np.arange(0.0, 0.8, DT)
    th1, th2 = 2 * 0.3 * OMEGA0, OMEGA0**2
    u_on, y_on = simulate_exact([th2, th1, 1.0], [1.0], t, [(300.0, 10 * OMEGA0, 0.0)])
    start = 300
    u = np.zeros_like(t)
    y = np.zeros_like(t)
    u[start:] = u_on[: t.size - start]
    y[start:] = y_on[: t.size - start]
    res = algebraic_estimates(u, y, DT, msd_model(), window=0.05)
    assert not res.valid[: start + 1].any()  # det exactly 0: all-zero windows
    assert np.all(res.level[50 : start + 1] == 0)
    moving = res.valid[start + 100 :]
    assert 0.8 < moving.mean() < 1.0  # some dips are rejected, most windows pass
    # the rule, checked literally:
    # valid <=> level >= 0.1 * median of the trailing 2L + 1 non-zero levels
    lv = res.level
    nz = np.flatnonzero(lv > 0)
    for k, e in enumerate(nz):
        ref = np.median(lv[nz[max(0, k - 100) : k + 1]])
        assert res.valid[e] == (lv[e] >= 0.1 * ref)
    # rejected windows sit in the dips: well below their neighbours 10 windows away
    rejected = np.flatnonzero(~moving) + start + 100
    rejected = rejected[rejected < t.size - 10]
    assert np.all(lv[rejected] < 0.2 * np.maximum(lv[rejected - 10], lv[rejected + 10]))
    assert res.parameters["theta2"] == pytest.approx(th2, rel=1e-6)


def test_trailing_median_with_history_equals_literal_median():
    from physid.estimators.algebraic import _trailing_median

    x = np.random.default_rng(0).random(300)
    for h in (0, 5, 40):
        for size in (1, 7, 51):
            out = _trailing_median(x[h:], x[:h], size)
            ref = [np.median(x[max(0, h + i - size + 1) : h + i + 1]) for i in range(x.size - h)]
            np.testing.assert_array_equal(out, ref)


def test_guard_rejects_the_worst_noisy_windows():
    t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=2.0)
    y = y + 0.01 * np.std(y) * np.random.default_rng(11).standard_normal(y.size)
    res = algebraic_estimates(u, y, DT, msd_model(), window=0.05)
    err = np.abs(res.estimates[:, 1] / th2 - 1)
    exists = np.isfinite(res.level)
    assert np.median(err[exists & ~res.valid]) > 3 * np.median(err[res.valid])


def test_block_least_squares_reduces_the_scatter():
    t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=2.0)
    y = y + 0.01 * np.std(y) * np.random.default_rng(12).standard_normal(y.size)
    spread = {}
    for K in (1, 8):
        res = algebraic_estimates(u, y, DT, msd_model(), window=0.05, block=K, block_stride=10)
        spread[K] = np.std(res.estimates[res.valid, 1])
    assert spread[8] < 0.5 * spread[1]


def test_pooled_least_squares_final_estimate():
    """final="lstsq" pools every valid window's equations: exact on clean data, and on a noisy
    stationary record (seeded) clearly more accurate than the median of the window estimates."""
    t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=2.0)
    clean = algebraic_estimates(u, y, DT, msd_model(), window=0.05, final="lstsq")
    assert clean.parameters["theta1"] == pytest.approx(th1, rel=1e-6)
    assert clean.parameters["theta2"] == pytest.approx(th2, rel=1e-6)
    rng = np.random.default_rng(21)
    err = {"median": [], "lstsq": []}
    for _ in range(3):
        noisy = y + 0.01 * np.std(y) * rng.standard_normal(y.size)
        for rule in err:
            res = algebraic_estimates(u, noisy, DT, msd_model(), window=0.05, final=rule)
            err[rule].append(abs(res.derived["natural_frequency"] / OMEGA0 - 1))
    assert np.mean(err["lstsq"]) < 0.5 * np.mean(err["median"])
    with pytest.raises(InputError, match="final must be one of"):
        algebraic_estimates(u, y, DT, msd_model(), final="mean")


def test_extra_derivatives_reject_high_frequency_disturbance():
    """The paper's section 5B: a sinusoid at 500 ω0 on the measurement (aliased at 1 kHz)."""
    t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=2.0)
    y = y + 1e-3 * np.sin(500 * OMEGA0 * t)
    err = {}
    for extra in (0, 2):
        res = algebraic_estimates(u, y, DT, msd_model(), window=0.1, extra_derivatives=extra, mu=5)
        err[extra] = abs(res.parameters["theta2"] / th2 - 1)
    assert err[2] < 0.5 * err[0]


# ------------------------------------------------------------------------------ API and errors
def test_estimator_fit_recording_and_result_object():
    t, u, y, th1, th2 = msd_signals(zeta=0.3, duration=0.5)
    rec = Recording.from_columns(t, {"u": u, "x": y})
    est = AlgebraicEstimator(msd_model(), window=0.05)
    assert est.fit(rec) is est
    res = est.result_
    assert isinstance(res, AlgebraicResult)
    assert res.names == ("theta1", "theta2")
    assert res.t.shape == (t.size,) and res.estimates.shape == (t.size, 2)
    omega = res.series("natural_frequency")
    assert np.nanmax(np.abs(omega[res.valid] / OMEGA0 - 1)) < 1e-6
    assert np.allclose(res.series("b0"), 1.0)
    d = json.loads(json.dumps(res.to_dict()))
    assert set(d["parameters"]) == {"theta1", "theta2"}  # fitted only (result schema)
    assert set(d["derived"]) == {"natural_frequency", "damping_ratio"}
    assert d["units"]["theta2"] == "1/s^2" and d["units"]["natural_frequency"] == "rad/s"
    assert "estimates" not in d and d["success"] is True
    assert "theta1" in res.summary()
    fig = res.plot(truth={"theta1": th1, "theta2": th2})
    assert len(fig.axes) >= 2
    # the same through fit_arrays and a 'y' channel
    rec_y = Recording.from_columns(t, {"u": u, "y": y})
    r2 = AlgebraicEstimator(msd_model(), window=0.05).fit(rec_y).result_
    r3 = AlgebraicEstimator(msd_model(), window=0.05).fit_arrays(t, u=u, y=y).result_
    np.testing.assert_array_equal(r2.estimates, r3.estimates)
    with pytest.warns(DeprecationWarning, match="fit_arrays"):
        r4 = AlgebraicEstimator(msd_model(), window=0.05).fit_arrays(u, y, DT).result_
    np.testing.assert_array_equal(r2.estimates, r4.estimates)


def test_inputs_are_not_mutated():
    t, u, y, *_ = msd_signals(duration=0.3)
    u0, y0 = u.copy(), y.copy()
    algebraic_estimates(u, y, DT, msd_model(), window=0.05, expanding=True, block=3)
    np.testing.assert_array_equal(u, u0)
    np.testing.assert_array_equal(y, y0)


def test_error_paths():
    t, u, y, *_ = msd_signals(duration=0.3)
    m = msd_model()
    with pytest.raises(SamplingError, match="longer than the record"):
        algebraic_estimates(u, y, DT, m, window=1.0)
    with pytest.raises(SamplingError, match="kernels need at least 7"):
        algebraic_estimates(u, y, DT, m, window=0.003)
    with pytest.raises(InputError, match="even number of sample intervals"):
        algebraic_estimates(u, y, DT, m, window=0.051, integration="simpson")
    with pytest.raises(EstimationError, match="no excitation"):
        algebraic_estimates(np.zeros(300), np.zeros(300), DT, m, window=0.05)
    with pytest.raises(EstimationError, match="cannot be estimated"):
        algebraic_estimates(np.zeros(y.size), y, DT, m, window=0.05, unknown=("theta1", "b0"))
    with pytest.raises(InputError, match="unknown coefficient name.*'omega'"):
        algebraic_estimates(u, y, DT, m, unknown=("omega",))
    with pytest.raises(InputError, match="not coefficients of the model"):
        algebraic_estimates(u, y, DT, m, known={"k": 1.0})
    with pytest.raises(InputError, match="both unknown and known"):
        algebraic_estimates(u, y, DT, m, unknown=("theta1", "theta2"), known={"theta1": 1.0})
    with pytest.raises(InputError, match="nothing is left to estimate"):
        algebraic_estimates(u, y, DT, m, known={"theta1": 1.0, "theta2": 100.0})
    with pytest.raises(InputError, match="mu must be >= order \\+ 1 = 3"):
        algebraic_estimates(u, y, DT, m, mu=2)
    with pytest.raises(InputError, match="integration must be one of"):
        algebraic_estimates(u, y, DT, m, integration="romberg")
    with pytest.raises(ShapeError, match="same length"):
        algebraic_estimates(u, y[:-1], DT, m)
    with pytest.raises(InputError, match="non-finite"):
        algebraic_estimates(np.where(t > 0.1, np.nan, u), y, DT, m)
    with pytest.raises(InputError, match="channel 'u' and an output channel"):
        AlgebraicEstimator(m).fit(Recording.from_columns(t, {"force": u, "x": y}))
    with pytest.raises(InputError, match="unknown setting"):
        StreamingAlgebraicEstimator(m, dt=DT, windw=0.05)
    with pytest.raises(SamplingError, match="not uniformly sampled"):
        t2 = t.copy()
        t2[5] += 3e-4
        AlgebraicEstimator(m).fit(Recording.from_columns(t2, {"u": u, "x": y}))


def test_known_without_unknown_estimates_the_remaining_coefficients():
    """known={"theta1": …} alone: the default unknowns drop theta1 (split_coefficients)."""
    t, u, y, th1, th2 = msd_signals(duration=0.3)
    res = algebraic_estimates(u, y, DT, msd_model(), known={"theta1": th1})
    assert res.names == ("theta2",)
    assert res.parameters["theta2"] == pytest.approx(th2, rel=1e-6)
    assert res.derived["damping_ratio"] == pytest.approx(0.3, rel=1e-6)


@pytest.mark.parametrize("final", ["lstsq", "bias-compensated"])
def test_output_offset_is_estimated(final, offset_msd):
    """A 1 cm sensor offset: the annihilator turns the constant into one more linear unknown
    (`_offset_column`), so θ and the offset come out exact, where the model without an offset
    is 15 % off in θ2."""
    t = np.arange(3000) * 1e-3
    u = np.sin(10 * t) + 0.5 * np.sin(23 * t)
    from scipy import signal

    from physid import Recording

    x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    rec = Recording(t, np.c_[u, x + 0.01], ["u", "x"])
    res = AlgebraicEstimator(offset_msd, final=final).fit(rec).result_
    assert res.success and res.names == ("theta1", "theta2", "offset")
    assert res.parameters["theta1"] == pytest.approx(2.0, rel=1e-4)
    assert res.parameters["theta2"] == pytest.approx(100.0, rel=1e-6)
    assert res.parameters["offset"] == pytest.approx(0.01, rel=1e-5)
    np.testing.assert_allclose(res.predict(rec)["x"], x + 0.01, atol=1e-6)
    plain = AlgebraicEstimator("msd").fit(rec).result_
    assert abs(plain.parameters["theta2"] / 100.0 - 1) > 0.1
