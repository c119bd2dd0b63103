"""White noise at an SNR, seeded generators, aliasing, and excitation signals."""

import numpy as np
import pytest

from physid.errors import InputError, ShapeError
from physid.signals.excitation import (
    Multisine,
    Sinusoid,
    delayed_steps,
    multisine,
    schroeder_phases,
    sinusoid,
)
from physid.signals.noise import (
    add_white_noise,
    alias_frequency,
    make_rng,
    noise_std_for_snr,
    sinusoidal_disturbance,
    snr_db,
)
from physid.simulate.references import filtered_steps


@pytest.mark.parametrize("target", [25.0, 50.0, 80.0])
def test_snr_matches_request_over_a_long_record(target):
    t = np.arange(1_000_000) * 1e-3
    x = 0.3 + np.sin(11.5 * t)  # an offset counts as signal power (mean square, not variance)
    noisy, noise = add_white_noise(x, snr_db=target, rng=12345)
    realised = 10 * np.log10(np.sum(x**2) / np.sum(noise**2))
    # standard deviation of the realised SNR: (10/ln10)·sqrt(2/n) = 0.0061 dB at n = 1e6
    assert realised == pytest.approx(target, abs=0.03)
    np.testing.assert_array_equal(noisy, x + noise)
    assert abs(np.mean(noise)) < 5 * np.std(noise) / 1e3  # zero mean within 5 standard errors


def test_snr_is_per_channel_and_the_input_is_not_mutated():
    rng = np.random.default_rng(0)
    x = np.column_stack([np.ones(200_000), 10 * np.ones(200_000)])
    before = x.copy()
    _, noise = add_white_noise(x, snr_db=20.0, rng=rng)
    np.testing.assert_array_equal(x, before)
    np.testing.assert_allclose(np.std(noise, axis=0), [0.1, 1.0], rtol=0.01)
    np.testing.assert_allclose(snr_db(x, noise), [20.0, 20.0], atol=0.05)
    np.testing.assert_allclose(noise_std_for_snr(x, 20.0), [0.1, 1.0])


def test_std_noise_and_same_seed_same_bits():
    x = np.zeros((1000, 3))
    a, na = add_white_noise(x, std=[0.1, 0.2, 0.0], rng=42)
    b, nb = add_white_noise(x, std=[0.1, 0.2, 0.0], rng=np.random.SeedSequence(42))
    c, _ = add_white_noise(x, std=[0.1, 0.2, 0.0], rng=43)
    np.testing.assert_array_equal(a, b)  # int seed and SeedSequence(seed) give the same bits
    assert not np.array_equal(a, c)
    np.testing.assert_array_equal(na[:, 2], 0.0)
    # the bits are those of numpy's default generator: std-normal draws scaled per channel
    ref = np.random.default_rng(42).standard_normal((1000, 3)) * [0.1, 0.2, 0.0]
    np.testing.assert_array_equal(na, ref)
    gen = make_rng(7)
    assert make_rng(gen) is gen


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({}, "exactly one of snr_db"),
        ({"snr_db": 10.0, "std": 1.0}, "exactly one of snr_db"),
        ({"std": -1.0}, "std must be finite and >= 0"),
        ({"std": [1.0, 2.0]}, "one value or one per channel"),
        ({"snr_db": float("inf")}, "snr_db must be finite"),
        ({"std": 1.0, "rng": "seed"}, "rng must be None"),
        ({"std": 1.0, "rng": -3}, "non-negative"),
    ],
)
def test_noise_error_paths(kwargs, match):
    with pytest.raises(InputError, match=match):
        add_white_noise(np.ones(5), **kwargs)


def test_zero_signal_has_no_snr():
    with pytest.raises(InputError, match="identically zero"):
        add_white_noise(np.zeros(10), snr_db=20.0, rng=0)


def test_alias_of_the_paper_disturbance():
    w0 = np.sqrt(400.0 / 3.0)
    w2 = 500 * w0  # 5773.50 rad/s, above the Nyquist frequency π/Δ = 3141.59 rad/s at Δ = 1 ms
    alias = alias_frequency(w2, 1e-3)
    assert alias == pytest.approx(2000 * np.pi - w2, rel=1e-14)
    assert alias == pytest.approx(509.6826, abs=1e-4)
    t = np.arange(5001) * 1e-3
    # the sampled disturbance is a (sign-flipped) sinusoid at the alias frequency
    np.testing.assert_allclose(
        sinusoidal_disturbance(t, 0.1, w2), -0.1 * np.sin(alias * t), atol=1e-10
    )
    assert alias_frequency(100.0, 1e-3) == pytest.approx(100.0)  # below Nyquist: unchanged
    assert alias_frequency(2 * np.pi * 1000.0, 1e-3) == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(InputError, match="dt must be finite and > 0"):
        alias_frequency(1.0, 0.0)


def test_sinusoid_object_and_function_agree():
    t = np.linspace(0, 2, 101)
    s = Sinusoid(2.0, 3.0, 0.5)
    np.testing.assert_array_equal(s(t), sinusoid(t, 2.0, 3.0, 0.5))
    assert s.components == ((2.0, 3.0, 0.5),)
    with pytest.raises(InputError, match="angular_frequency must be >= 0"):
        Sinusoid(1.0, -1.0)


def test_multisine_schroeder_phases_and_crest_factor():
    np.testing.assert_allclose(schroeder_phases(4), [0.0, -np.pi / 2, -3 * np.pi / 2, -3 * np.pi])
    k = np.arange(1, 21)
    t = np.arange(100_000) * (2 * np.pi / 100_000)  # one period of the fundamental (1 rad/s)
    x = multisine(t, k.astype(float))
    crest = np.abs(x).max() / np.sqrt(np.mean(x**2))
    zero_phase = multisine(t, k.astype(float), phases=np.zeros(20))
    crest_zero = np.abs(zero_phase).max() / np.sqrt(np.mean(zero_phase**2))
    assert crest < 2.0 < crest_zero  # Schroeder: ~1.7; all phases equal: sqrt(2·20)=6.3
    assert np.mean(x**2) == pytest.approx(20 * 0.5, rel=1e-6)  # power = Σ A²/2
    ms = Multisine([1.0, 2.0], amplitudes=3.0, phases=[0.0, 1.0])
    np.testing.assert_allclose(ms(t[:10]), 3 * np.sin(t[:10]) + 3 * np.sin(2 * t[:10] + 1.0))
    with pytest.raises(ShapeError, match="one value or one per frequency"):
        Multisine([1.0, 2.0], amplitudes=[1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="schroeder"):
        Multisine([1.0], phases="random")


def test_delayed_steps_unit_step_convention():
    t = np.arange(11) * 0.1
    steps = delayed_steps(t, [0.3, 0.7], [0.5, -1.0])
    assert steps.shape == (11, 2)
    np.testing.assert_array_equal(steps[:, 0], np.where(np.arange(11) >= 3, 0.5, 0.0))
    np.testing.assert_array_equal(steps[:, 1], np.where(np.arange(11) >= 7, -1.0, 0.0))
    with pytest.raises(ShapeError, match="one per step"):
        delayed_steps(t, [0.3, 0.7], [1.0, 2.0, 3.0])


def test_filtered_steps_paper_alignment_leads_by_m_samples():
    dt = 1e-3
    t = np.arange(10001) * dt
    paper = filtered_steps(t, [1.0, 3.0, 5.0, 7.0], 0.5)
    centred = filtered_steps(t, [1.0, 3.0, 5.0, 7.0], 0.5, alignment="centred")
    assert paper.values.shape == (10001 - 200, 4)
    np.testing.assert_array_equal(paper.values, centred.values)
    assert paper.t[0] == 0.0 and centred.t[0] == pytest.approx(0.1)
    np.testing.assert_allclose(centred.t - paper.t, 0.1, atol=1e-12)
    assert paper.lead == pytest.approx(0.1) and centred.lead == 0.0
    # Zero-phase filter of a step sampled with H(0)=1: the half-height point is midway between
    # the last 0 sample (0.999 s) and the first 0.5 sample (1.000 s) -> 0.9995 s centred,
    # 0.8995 s with the paper's re-labelling.
    for ref, mid in ((centred, 0.9995), (paper, 0.8995)):
        x = ref.values[:, 0]
        i = np.nonzero(x >= 0.25)[0][0]
        t_half = ref.t[i - 1] + (0.25 - x[i - 1]) / (x[i] - x[i - 1]) * dt
        assert t_half == pytest.approx(mid, abs=2e-5)
    # Exactly 0 before the window reaches the step and the step height after it (unit DC gain).
    assert np.all(paper.values[paper.t < 0.8, 0] == 0.0)
    np.testing.assert_allclose(paper.values[paper.t > 1.0, 0], 0.5, atol=1e-12)
    np.testing.assert_allclose(
        paper.sample([-1.0, 20.0]), [[0, 0, 0, 0], [0.5, 0.5, 0.5, 0.5]], atol=1e-12
    )
    with pytest.raises(InputError, match="alignment must be"):
        filtered_steps(t, [1.0], alignment="causal")
