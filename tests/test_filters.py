"""Tests of the paper's differential filters (Cedro & Janecki, section 3)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, signal

import physid.estimators.recursive as recursive
from physid.errors import InputError, PhysidError, SamplingError, ShapeError
from physid.filters import (
    DifferentialFilter,
    StreamingStateVariableFilter,
    design_filter,
    filter_derivatives,
    harris_window,
    ideal_impulse_response,
    state_variable_filter,
    svf_transient_samples,
)

M, CUTOFF, DT = 100, 0.2, 1e-3  # the paper's settings: Filtr[100, 0.2, 0.001, ...]


# --------------------------------------------------------------------------- literal transcription
# A slow, literal transcription of the paper's Mathematica code (section 3): the closed forms
# FullSimplify returns for h0, h1, h2, the Harris window, the κ factors and the For loops with
# 1-based indices, including Filtr2's use of the global κH1 / h0 from the last Filtr call.
def _paper_h0(n, ng):
    return ng / math.pi if n == 0 else math.sin(ng * n) / (math.pi * n)


def _paper_h1(n, ng, delta):
    if n == 0:
        return 0.0
    return (ng * n * math.cos(ng * n) - math.sin(ng * n)) / (math.pi * delta * n**2)


def _paper_h2(n, ng, delta):
    if n == 0:
        return -(ng**3) / (3 * math.pi * delta**2)
    x = ng * n
    return (2 * math.sin(x) - 2 * x * math.cos(x) - x**2 * math.sin(x)) / (
        math.pi * delta**2 * n**3
    )


def _paper_w(n, big_m):
    return (
        0.36
        + 0.49 * math.cos(n * math.pi / big_m)
        + 0.14 * math.cos(2 * n * math.pi / big_m)
        + 0.01 * math.cos(3 * n * math.pi / big_m)
    )


def _paper_loop(x, taps, big_m):
    """xf = Table[0, {NN-2M-1}]; For[i = M+1, i <= NN-M-1, i++, xf[[i-M]] = x[[i-M..i+M]].hp]."""
    nn = len(x)
    xf = [0.0] * (nn - 2 * big_m - 1)
    for i in range(big_m + 1, nn - big_m - 1 + 1):  # 1-based i
        acc = 0.0
        for k in range(i - big_m, i + big_m + 1):  # 1-based k
            acc += x[k - 1] * taps[k - (i - big_m)]
        xf[i - big_m - 1] = acc
    return np.array(xf)


def paper_h0p(big_m, ng):
    """Filtr's table: h0p[[i+M+1]] = h0[i] wHarris[i] / κH1, κH1 = Σ h0 wHarris."""
    kappa_h1 = sum(_paper_h0(n, ng) * _paper_w(n, big_m) for n in range(-big_m, big_m + 1))
    h0p = [0.0] * (2 * big_m + 1)
    for i in range(-big_m, big_m + 1):
        h0p[i + big_m] = _paper_h0(i, ng) * _paper_w(i, big_m) / kappa_h1
    return h0p, kappa_h1


def paper_h1p(big_m, ng, delta):
    """Filtr1's table: h1p[[i+M+1]] = h1[i] wHarris[i] (-1/κH2), κH2 = Σ h1 wHarris (0 - nΔ)."""
    kappa_h2 = sum(
        _paper_h1(n, ng, delta) * _paper_w(n, big_m) * (0 - n * delta)
        for n in range(-big_m, big_m + 1)
    )
    h1p = [0.0] * (2 * big_m + 1)
    for i in range(-big_m, big_m + 1):
        h1p[i + big_m] = _paper_h1(i, ng, delta) * _paper_w(i, big_m) * (-1 / kappa_h2)
    return h1p


def paper_h2p(big_m, ng, delta, kappa_h1):
    """Filtr2's table, with the global κH1 / h0 left over from the last Filtr call."""
    kappa_h3 = sum(_paper_h2(n, ng, delta) * _paper_w(n, big_m) for n in range(-big_m, big_m + 1))

    def h0fh(n):
        return _paper_h0(n, ng) * _paper_w(n, big_m) / kappa_h1

    def g(n):
        return _paper_h2(n, ng, delta) * _paper_w(n, big_m) - kappa_h3 * h0fh(n)

    kappa_h4 = sum(g(n) * (0 - (delta * n) ** 2) for n in range(-big_m, big_m + 1))
    h2p = [0.0] * (2 * big_m + 1)
    for i in range(-big_m, big_m + 1):
        h2p[i + big_m] = -2 / kappa_h4 * g(i)
    return h2p


def paper_filtr(big_m, ng, delta, x):
    h0p, kappa_h1 = paper_h0p(big_m, ng)
    return _paper_loop(x, h0p, big_m), kappa_h1


def paper_filtr1(big_m, ng, delta, x):
    return _paper_loop(x, paper_h1p(big_m, ng, delta), big_m)


def paper_filtr2(big_m, ng, delta, x, kappa_h1):
    return _paper_loop(x, paper_h2p(big_m, ng, delta, kappa_h1), big_m)


@pytest.fixture(scope="module")
def noisy_signal():
    rng = np.random.default_rng(20240501)
    t = DT * np.arange(700)
    x = (
        0.5 * np.sin(2 * np.pi * 3.0 * t)
        + 0.2 * np.cos(2 * np.pi * 11.0 * t)
        + 1e-3 * rng.standard_normal(t.size)
    )
    return t, x


@pytest.mark.parametrize("method", ["fft", "direct"])
def test_matches_literal_transcription_of_the_papers_loops(noisy_signal, method):
    """End to end (design + application) against the paper's code, to 1e-12 of the scale.

    Exact equality is impossible in principle here for two reasons: (1) our taps evaluate the
    same closed forms through spherical Bessel functions (no cancellation at small Ω_g n) and
    make the symmetry exact, so they differ from the paper's tables in the last bits (~1e-15
    relative); (2) the FFT path rounds differently from a sum of products. The application
    stage alone is bit-exact for ``method="direct"``: see the next two tests.
    """
    _, x = noisy_signal
    lit0, kappa_h1 = paper_filtr(M, CUTOFF, DT, list(x))
    lit1 = paper_filtr1(M, CUTOFF, DT, list(x))
    lit2 = paper_filtr2(M, CUTOFF, DT, list(x), kappa_h1)
    for kind, literal in (("lowpass", lit0), ("first", lit1), ("second", lit2)):
        ours = design_filter(kind, M, CUTOFF, DT).apply(x, paper=True, method=method)
        assert ours.shape == literal.shape == (x.size - 2 * M - 1,)
        scale = np.max(np.abs(literal))
        # agreement to 1e-12 of the output's scale (summation order and libm differ at ~1e-15)
        np.testing.assert_allclose(ours, literal, rtol=0, atol=1e-12 * scale)


def _filter_with_taps(kind, taps):
    return DifferentialFilter(
        kind=kind,
        order={"lowpass": 0, "first": 1, "second": 2}[kind],
        half_width=M,
        cutoff=CUTOFF,
        dt=DT,
        taps=np.array(taps, dtype=float),
    )


@pytest.mark.parametrize("paper", [True, False])
def test_direct_method_is_bit_for_bit_the_papers_loop_with_the_papers_tables(noisy_signal, paper):
    # The paper's h0p/h1p/h2p tables (transcribed above) applied by method="direct" give exactly
    # the numbers of the literal For loop: same products, same left-to-right summation order.
    _, x = noisy_signal
    h0p, kappa_h1 = paper_h0p(M, CUTOFF)
    tables = {
        "lowpass": h0p,
        "first": paper_h1p(M, CUTOFF, DT),
        "second": paper_h2p(M, CUTOFF, DT, kappa_h1),
    }
    for kind, table in tables.items():
        literal = _paper_loop(list(x), table, M)
        ours = _filter_with_taps(kind, table).apply(x, paper=True, method="direct")
        if not paper:  # the loop stops one sample early; compare the common rows
            ours = _filter_with_taps(kind, table).apply(x, method="direct")[:-1]
        np.testing.assert_array_equal(ours, literal)


def test_direct_method_is_bit_for_bit_the_literal_loop_with_our_taps(noisy_signal):
    _, x = noisy_signal
    two = np.column_stack([x, x[::-1] ** 3])
    for kind in ("lowpass", "first", "second"):
        f = design_filter(kind, M, CUTOFF, DT)
        ours = f.apply(two, paper=True, method="direct")
        for c in range(2):
            np.testing.assert_array_equal(ours[:, c], _paper_loop(list(two[:, c]), f.taps, M))


def test_taps_equal_the_papers_h_p_tables():
    _, kappa_h1 = paper_filtr(5, 0.7, 0.01, [0.0] * 12)
    h0p = [_paper_h0(i, 0.7) * _paper_w(i, 5) / kappa_h1 for i in range(-5, 6)]
    np.testing.assert_allclose(design_filter("lowpass", 5, 0.7, 0.01).taps, h0p, rtol=1e-13)


# --------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("order", [0, 1, 2])
def test_closed_form_impulse_response_matches_quadrature_of_eq4(order):
    # h_k[n] = (1/2π) ∫_{-Ωg}^{Ωg} (jΩ/Δ)^k e^{jΩn} dΩ. The imaginary part of the integrand is odd
    # in Ω and integrates to 0; the real part is even: Re[(jΩ/Δ)^k e^{jΩn}] = (Ω/Δ)^k times
    # cos(Ωn) (k=0), -sin(Ωn) (k=1), -cos(Ωn) (k=2). QUADPACK's oscillatory rule does the rest.
    big_m, cutoff, dt = 30, 0.9, 0.01
    closed = ideal_impulse_response(order, big_m, cutoff, dt)
    weight, sign = {0: ("cos", 1.0), 1: ("sin", -1.0), 2: ("cos", -1.0)}[order]
    scale = cutoff ** (order + 1) / dt**order
    for n in range(-big_m, big_m + 1):
        if n == 0 and weight == "sin":
            numeric = 0.0  # sin(0) = 0: h1[0] = 0 exactly
        else:
            half = integrate.quad(
                lambda w: sign * (w / dt) ** order,
                0.0,
                cutoff,
                weight=weight,
                wvar=n,
                epsabs=1e-14 * scale,
                epsrel=1e-13,
            )[0]
            numeric = 2 * half / (2 * np.pi)
        assert closed[n + big_m] == pytest.approx(numeric, rel=1e-10, abs=1e-13 * scale)


def test_closed_forms_are_accurate_at_small_cutoff():
    # the spherical-Bessel forms avoid the cancellation of (x cos x - sin x)/x² at small x
    cutoff, dt = 1e-4, 1.0
    h1 = ideal_impulse_response(1, 3, cutoff, dt)
    h2 = ideal_impulse_response(2, 3, cutoff, dt)
    n = np.arange(-3, 4)
    x = cutoff * n
    # leading Taylor terms: h1 ≈ -Ωg² x/(3π) (1 - x²/10),  h2 ≈ -Ωg³/(3π) (1 - 3x²/10)
    np.testing.assert_allclose(h1, -(cutoff**2) * x / (3 * np.pi) * (1 - x**2 / 10), rtol=1e-12)
    np.testing.assert_allclose(h2, -(cutoff**3) / (3 * np.pi) * (1 - 3 * x**2 / 10), rtol=1e-12)


def test_harris_window_values():
    w = harris_window(4)
    assert w[0] == pytest.approx(0.0, abs=1e-15) and w[-1] == pytest.approx(0.0, abs=1e-15)
    assert w[4] == pytest.approx(1.0, abs=1e-15)  # 0.36 + 0.49 + 0.14 + 0.01
    np.testing.assert_array_equal(w, w[::-1])


# ---------------------------------------------------------------- exactness on polynomials
T0 = 2.0  # start away from 0 so that the tests see offsets, not just scaled powers
POLY_CASES = [
    ("lowpass", lambda t: np.ones_like(t), lambda t: np.ones_like(t)),
    ("lowpass", lambda t: t, lambda t: t),
    ("first", lambda t: np.ones_like(t), lambda t: np.zeros_like(t)),
    ("first", lambda t: t, lambda t: np.ones_like(t)),
    ("first", lambda t: t**2, lambda t: 2 * t),
    ("second", lambda t: np.ones_like(t), lambda t: np.zeros_like(t)),
    ("second", lambda t: t, lambda t: np.zeros_like(t)),
    ("second", lambda t: t**2, lambda t: 2 * np.ones_like(t)),
    ("second", lambda t: t**3, lambda t: 6 * t),
]


@pytest.mark.parametrize("method", ["fft", "direct"])
@pytest.mark.parametrize(("kind", "poly", "expected"), POLY_CASES)
def test_exact_on_polynomials(kind, poly, expected, method):
    t = T0 + DT * np.arange(600)
    f = design_filter(kind, M, CUTOFF, DT)
    y = f.apply(poly(t), method=method)
    want = expected(f.output_time(t))
    # relative to the size of what is differentiated (t³ ~ 10 here), absolute 1e-9 near 0
    tol = 1e-9 * max(1.0, float(np.max(np.abs(want))))
    np.testing.assert_allclose(y, want, rtol=0, atol=tol)


def test_correlation_not_convolution_sign_on_a_ramp():
    t = DT * np.arange(500)
    ramp = 3.0 * t
    f = design_filter("first", M, CUTOFF, DT)
    np.testing.assert_allclose(f.apply(ramp), 3.0, rtol=1e-10)
    # the trap the paper's -1/κH2 avoids: convolving with the same taps flips the sign
    convolved = np.convolve(ramp, f.taps, mode="valid")
    np.testing.assert_allclose(convolved, -3.0, rtol=1e-10)


# --------------------------------------------------------------------------- frequency domain
@pytest.mark.parametrize("kind", ["lowpass", "first", "second"])
def test_passband_flat_within_1e_minus_3(kind):
    f = design_filter(kind, M, CUTOFF, DT)
    omega = np.linspace(CUTOFF / 400, CUTOFF / 4, 400)
    ratio = f.frequency_response(omega) / f.ideal_response(omega)
    assert np.max(np.abs(ratio - 1)) <= 1e-3
    if kind == "lowpass":
        assert f.frequency_response(0.0) == pytest.approx(1.0, abs=1e-14)


@pytest.mark.parametrize("kind", ["lowpass", "first", "second"])
def test_stopband_attenuation_at_least_60_db_beyond_1_5_cutoff(kind):
    # attenuation relative to the largest pass-band gain |H| (for d/dt that is ~Ωg/Δ at the edge)
    f = design_filter(kind, M, CUTOFF, DT)
    passband = np.abs(f.frequency_response(np.linspace(0, CUTOFF, 2001))).max()
    stop = np.abs(f.frequency_response(np.linspace(1.5 * CUTOFF, np.pi, 20001))).max()
    attenuation_db = 20 * np.log10(passband / stop)
    assert attenuation_db >= 60.0


@pytest.mark.parametrize("kind", ["lowpass", "first", "second"])
def test_frequency_response_predicts_the_output_on_a_sinusoid(kind):
    f = design_filter(kind, 40, 0.5, 0.01)
    n = np.arange(400)
    omega0 = 0.23
    y = f.apply(np.sin(omega0 * n))
    h = f.frequency_response(omega0)
    # correlation: Σ c[k] sin(Ω0 (i + k)) = Im(H(Ω0) e^{jΩ0 i})
    i = n[f.valid_slice(n.size)]
    np.testing.assert_allclose(y, np.imag(h * np.exp(1j * omega0 * i)), atol=1e-10 * abs(h))


def test_white_noise_gain_matches_filtered_noise():
    f = design_filter("first", M, CUTOFF, DT)
    noise = np.random.default_rng(7).standard_normal((200_000, 2))
    measured = f.apply(noise).std()
    assert measured == pytest.approx(f.white_noise_gain, rel=0.02)
    assert f.white_noise_gain == pytest.approx(np.sqrt(np.sum(f.taps**2)), rel=1e-15)


# --------------------------------------------------------------------------- shapes and alignment
def test_shapes_alignment_and_paper_length():
    f = design_filter("lowpass", 10, 0.5, 0.1)
    t = 0.1 * np.arange(50)
    x = np.column_stack([t, 2 * t, -t])
    y = f.apply(x)
    assert y.shape == (50 - 20, 3)
    np.testing.assert_allclose(y, x[10:40], atol=1e-12)  # low-pass is exact on a ramp
    assert f.apply(x, paper=True).shape == (29, 3)
    np.testing.assert_array_equal(f.output_time(t), t[10:40])
    np.testing.assert_array_equal(f.output_time(t, paper=True), t[10:39])
    assert f.valid_slice(50) == slice(10, 40)
    assert f.delay == 10 and f.delay_seconds == pytest.approx(1.0)
    assert f.apply(t).shape == (30,)  # 1-D in, 1-D out
    np.testing.assert_allclose(f.apply(x)[:, 1], f.apply(x[:, 1]), rtol=1e-14, atol=1e-14)


def test_does_not_mutate_input_and_accepts_read_only():
    x = np.random.default_rng(1).standard_normal((300, 2))
    x.setflags(write=False)
    before = x.copy()
    design_filter("second", 20, 0.4, 0.01).apply(x)
    np.testing.assert_array_equal(x, before)


def test_kind_aliases_and_attributes():
    a = design_filter(1, 10, 0.5, 0.1)
    b = design_filter("first", 10, 0.5, 0.1)
    assert isinstance(a, DifferentialFilter)
    assert a.kind == "first" and a.order == 1 and a.n_taps == 21
    np.testing.assert_array_equal(a.taps, b.taps)
    assert not a.taps.flags.writeable
    np.testing.assert_array_equal(a.taps, -a.taps[::-1])  # exactly antisymmetric


def test_filter_derivatives_aligned_on_a_sine():
    dt = 1e-3
    t = dt * np.arange(2000)
    omega = 2 * np.pi * 2.0  # 2 Hz, deep in the pass band of Ωg = 0.2 (31.8 Hz)
    x = np.column_stack([np.sin(omega * t), np.cos(omega * t)])
    d = filter_derivatives(x, t, M, CUTOFF)
    tt = d.t[:, None]
    np.testing.assert_array_equal(d.t, t[M:-M])
    # within the pass-band tolerance |H/H_ideal - 1| <= 1e-3 (measured: ~1.4e-4 for d²/dt² here)
    want = np.column_stack([np.sin(omega * d.t), np.cos(omega * d.t)])
    np.testing.assert_allclose(d.value, want, atol=1e-3)
    np.testing.assert_allclose(d.first[:, :1], omega * np.cos(omega * tt), atol=1e-3 * omega)
    np.testing.assert_allclose(
        d.second[:, :1], -(omega**2) * np.sin(omega * tt), atol=1e-3 * omega**2
    )
    assert d.delay == M and d.half_width == M and d.cutoff == CUTOFF
    assert d.first_filter.dt == pytest.approx(dt)


# --------------------------------------------------------------------------- error paths
@pytest.mark.parametrize("bad", [0, -3, 1.5, True, "100"])
def test_bad_half_width(bad):
    with pytest.raises(InputError, match=r"half_width must be an integer >= 1.*It is M"):
        design_filter("lowpass", bad, CUTOFF, DT)


@pytest.mark.parametrize("bad", [0.0, -0.1, 3.2, float("nan"), "x"])
def test_bad_cutoff(bad):
    with pytest.raises(InputError, match=r"cutoff \(Ω_g, rad/sample\) must"):
        design_filter("lowpass", M, bad, DT)


def test_cutoff_pi_is_allowed():
    f = design_filter("lowpass", 5, np.pi, 1.0)
    np.testing.assert_allclose(f.taps, np.eye(11)[5], atol=1e-15)  # all-pass: a unit impulse


@pytest.mark.parametrize("bad", [0.0, -1e-3, float("inf"), None])
def test_bad_dt(bad):
    with pytest.raises(InputError, match=r"dt \(sample period, s\) must"):
        design_filter("first", M, CUTOFF, bad)


@pytest.mark.parametrize("bad", ["third", 3, -1, None])
def test_bad_kind(bad):
    with pytest.raises(InputError, match="kind must be 'lowpass', 'first' or 'second'"):
        design_filter(bad, M, CUTOFF, DT)


def test_record_shorter_than_filter():
    f = design_filter("first", 10, 0.5, 0.1)
    with pytest.raises(SamplingError, match=r"needs at least 21 samples but the record has 20"):
        f.apply(np.zeros(20))
    with pytest.raises(SamplingError, match=r"needs at least 22 samples .* has 21"):
        f.apply(np.zeros(21), paper=True)
    assert isinstance(
        pytest.raises(PhysidError, f.output_time, np.arange(5.0)).value, SamplingError
    )


def test_bad_array_inputs():
    f = design_filter("lowpass", 2, 0.5, 0.1)
    with pytest.raises(ShapeError, match=r"x must have shape \(n_samples, n_channels\)"):
        f.apply(np.zeros((10, 2, 2)))
    x = np.zeros((10, 2))
    x[4, 1] = np.nan
    with pytest.raises(InputError, match=r"non-finite value \(nan\) in column 1, row 4"):
        f.apply(x)
    with pytest.raises(InputError, match="method must be 'fft' or 'direct'"):
        f.apply(np.zeros(10), method="slow")
    with pytest.raises(InputError, match="x must be real numbers; got a complex array"):
        f.apply(np.ones(10, dtype=complex))
    with pytest.raises(InputError, match="x must be real numbers; could not convert"):
        f.apply(["a"] * 10)


def test_filter_derivatives_errors():
    t = np.array([0.0, 0.1, 0.2, 0.35, 0.4, 0.5, 0.6])
    with pytest.raises(SamplingError, match="not uniformly sampled"):
        filter_derivatives(np.zeros(7), t, 1, 0.5)
    with pytest.raises(ShapeError, match="one row per sample of t"):
        filter_derivatives(np.zeros(5), 0.1 * np.arange(7), 1, 0.5)


# --------------------------------------------------------------------------- filter_signal
def test_filter_signal_returns_aligned_read_only_times_and_values():
    dt = 0.01
    t = 5.0 + dt * np.arange(80)
    x = np.column_stack([t**2, np.sin(t)])
    f = design_filter("first", 10, 0.5, dt)
    out = f.filter_signal(x, t)
    np.testing.assert_array_equal(out.t, t[10:70])
    np.testing.assert_array_equal(out.values, f.apply(x))
    np.testing.assert_allclose(out.values[:, 0], 2 * out.t, rtol=1e-9)  # d(t²)/dt at its time
    assert out.n_samples == 60
    with pytest.raises(ValueError, match="read-only"):
        out.values[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        out.t[0] = 1.0
    with pytest.raises(AttributeError):
        out.t = t  # frozen
    short = f.filter_signal(x[:, 0], t, paper=True)
    assert short.values.shape == short.t.shape == (59,)


def test_filter_signal_errors():
    t = 0.01 * np.arange(80)
    f = design_filter("lowpass", 10, 0.5, 0.01)
    with pytest.raises(SamplingError, match=r"sample period 0\.02 s but the filter was designed"):
        f.filter_signal(np.zeros(80), 2 * t)
    with pytest.raises(ShapeError, match=r"one row per sample of t \(80\); got x of shape \(79,\)"):
        f.filter_signal(np.zeros(79), t)
    with pytest.raises(SamplingError, match=r"needs at least 21 samples but the record has 15"):
        f.filter_signal(np.zeros(15), t[:15])


# ------------------------------------------------------------------ state-variable filter
def test_svf_lives_in_filters_and_recursive_uses_the_same_objects():
    assert state_variable_filter.__module__ == "physid.filters.state_variable"
    assert recursive.state_variable_filter is state_variable_filter
    assert recursive.StreamingStateVariableFilter is StreamingStateVariableFilter
    assert recursive.svf_transient_samples is svf_transient_samples


def test_svf_dc_gain_is_one_and_derivatives_of_a_constant_vanish():
    d = state_variable_filter(np.full(4000, 2.5), 1e-3, 20.0, n_derivatives=2, filter_order=3)
    np.testing.assert_allclose(d[-1], [2.5, 0.0, 0.0], rtol=0, atol=1e-8)


@pytest.mark.parametrize("dt", [1e-3, 5e-4])
def test_svf_of_a_sinusoid_is_the_analytic_steady_state(dt):
    """w^(i) = Im((jω)^i F(jω) e^{jωt}) after the transient, F the analog Butterworth.

    The FOH discretisation is exact for piecewise-linear input; a sine differs from its chords by
    the interpolation error, relative size (ω dt)² / 12 (1.32e-5 at 1 ms, 3.3e-6 at 0.5 ms), so the
    tolerance is 1.1 (ω dt)² / 12 of each derivative's amplitude, and halving dt divides it by 4.
    """
    fc, order, w0 = 20.0, 3, 2 * np.pi * 2.0
    t = np.arange(int(round(2.0 / dt))) * dt
    d = state_variable_filter(np.sin(w0 * t), dt, fc, n_derivatives=2, filter_order=order)
    b, a = signal.butter(order, 2 * np.pi * fc, analog=True)
    H = signal.freqs(b, a, [w0])[1][0]
    keep = t > 0.5  # 500 ms ≫ svf_transient_samples(20, dt, 3) samples
    assert svf_transient_samples(fc, dt, order) * dt < 0.5
    tol = 1.1 * (w0 * dt) ** 2 / 12
    for i in range(3):
        ref = np.imag((1j * w0) ** i * H * np.exp(1j * w0 * t))
        err = np.abs(d[keep, i] - ref[keep]).max() / (w0**i * abs(H))
        assert err < tol, (i, err, tol)
        assert err > 0.5 * (w0 * dt) ** 2 / 12  # the error is the hold's, not something smaller
