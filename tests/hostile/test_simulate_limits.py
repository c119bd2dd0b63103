"""``physid simulate msd`` refuses, before allocating anything, a grid too large for memory and
a system (or jump, or input) too fast to be sampled: the number, the flag and the fix."""

from __future__ import annotations

import re

import pytest

from physid import _resources
from physid.errors import InputError
from physid.simulate import simulate_msd

from ._cases import case_ids, check_case

OUT = ["--out", "{tmp}/x.csv"]
FAST = r"at most 1e6 per sample \(a system that fast cannot be sampled meaningfully"

CASES = [
    (
        "dt-tiny",
        ["simulate", "msd", *OUT, "--dt", "1e-12"],
        2,
        re.escape(
            "physid: error: --duration 5 s at --dt 1e-12 s asks for 5e+12 samples; at most 5e7 "
            "(raise --dt, or shorten --duration)."
        ),
    ),
    (
        "duration-huge",
        ["simulate", "msd", *OUT, "--duration", "100000"],
        2,
        re.escape("--duration 100000 s at --dt 0.001 s asks for 1e+08 samples; at most 5e7"),
    ),
    (
        "jump-stiffness-1e308",
        ["simulate", "msd", *OUT, "--jumps", "0.5:1e308"],
        2,
        r"physid: error: the jump at t = 0\.5 s: the natural frequency ω0 = √\(k/m\) is "
        rf"5\.77e\+153 rad/s, 5\.77e\+150 per sample at --dt 0\.001 s; {FAST}.*; check its "
        r"value in --jumps\.",
    ),
    (
        "jump-stiffness-inf",
        ["simulate", "msd", *OUT, "--jumps", "0.5:inf"],
        2,
        re.escape("physid: error: --jumps stiffness [N/m] must be finite; got 'inf'."),
    ),
    (
        "second-jump-huge",
        ["simulate", "msd", *OUT, "--jumps", "0.5:1e3,1:1e40"],
        2,
        rf"the jump at t = 1 s: the natural frequency .* 5\.77e\+16 per sample .*{FAST}",
    ),
    (
        "stiffness-1e308",
        ["simulate", "msd", *OUT, "--stiffness", "1e308"],
        2,
        rf"the system: the natural frequency .* is 5\.77e\+153 rad/s.*{FAST}.*; check "
        r"--stiffness, --damping and --mass \(or --natural-frequency\), or lower --dt\.",
    ),
    (
        "damping-1e300",
        ["simulate", "msd", *OUT, "--damping", "1e300"],
        2,
        rf"the damping rate θ1 = c/m is 3\.33e\+299 1/s, 3\.33e\+296 per sample .*{FAST}",
    ),
    (
        "mass-tiny",
        ["simulate", "msd", *OUT, "--mass", "1e-300"],
        2,
        rf"the system: the natural frequency ω0 = √\(k/m\) is 2e\+151 rad/s.*{FAST}",
    ),
    (
        "ratio-1e300",
        ["simulate", "msd", *OUT, "--ratio", "1e300"],
        2,
        re.escape(
            "the input's angular frequency ω1 = 1.15e+301 rad/s is 1.15e+298 rad per sample at "
            "--dt 0.001 s; at most 1e6 per sample (far above the Nyquist frequency); lower --ratio "
            "(ω1 = Z ω0)."
        ),
    ),
    (
        "natural-frequency-overflow",
        ["simulate", "msd", *OUT, "--natural-frequency", "1e200", "--damping-ratio", "0.1"],
        2,
        r"the system: the natural frequency ω0 = √\(k/m\) is not finite \(inf\)",
    ),
]


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_simulate_limits(case_id, argv, expected_exit, message_regex, hostile):
    check_case(hostile, argv, expected_exit, message_regex)


def test_memory_is_estimated_before_allocating(hostile, monkeypatch):
    monkeypatch.setattr(_resources, "available_memory", lambda: 8_000_000_000)
    check_case(
        hostile,
        ["simulate", "msd", *OUT, "--duration", "40000"],
        2,
        re.escape(
            "physid: error: simulating --duration 40000 s at --dt 0.001 s (4e+07 samples) needs "
            "about 9.6 GB of memory, more than half of the 8 GB available; raise --dt or shorten "
            "--duration."
        ),
    )
    with pytest.raises(
        InputError,
        match=re.escape(
            "simulating duration=1000.0 s at dt=1e-05 s (1e+08 samples) needs about 24 GB of "
            "memory, more than half of the 8 GB available; raise dt or shorten duration."
        ),
    ):
        simulate_msd(natural_frequency=10.0, damping_ratio=0.1, amplitude=1.0, ratio=1.0,
                     duration=1000.0, dt=1e-5)  # fmt: skip


def test_library_refuses_an_absurd_jump():
    with pytest.raises(InputError, match=r"the jump at t = 0\.5 s: .* check its value in jumps"):
        simulate_msd(mass=3.0, damping=0.05, stiffness=400.0, amplitude=1.0, ratio=1.0,
                     jumps=[(0.5, 1e308)])  # fmt: skip


def test_ordinary_jumps_still_simulate():
    rec = simulate_msd(mass=3.0, damping=0.05, stiffness=400.0, amplitude=1.0, ratio=1.0,
                       duration=1.0, jumps=[(0.5, 600.0)], dt=1e-3)  # fmt: skip
    assert rec.n_samples == 1001
    assert [j["time"] for j in rec.metadata["jumps"]] == [0.5]
