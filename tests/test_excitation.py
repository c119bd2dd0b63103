"""Fourier excitation design (physid.analysis.excitation) and ``physid design-excitation``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import physid
from physid.analysis.excitation import design_excitation, excitation_limits, fourier_trajectory
from physid.cli import main
from physid.errors import InputError


@pytest.fixture(scope="module")
def arm():
    return physid.load_model("manipulator")


@pytest.fixture(scope="module")
def design(arm):
    return design_excitation(
        arm, harmonics=3, period=4.0, velocity=2.0, acceleration=8.0, n_random=6, max_iter=4
    )


def test_fourier_series_derivatives_match_finite_differences():
    rng = np.random.default_rng(0)
    c = rng.normal(size=(2, 2, 4))
    t = np.linspace(0.0, 3.0, 30001)
    q, qd, qdd = fourier_trajectory(c, t, 3.0, [0.1, -0.2])
    np.testing.assert_allclose(np.gradient(q, t, axis=0)[5:-5], qd[5:-5], atol=1e-6)
    np.testing.assert_allclose(np.gradient(qd, t, axis=0)[5:-5], qdd[5:-5], atol=1e-5)
    np.testing.assert_allclose(q[0], [0.1, -0.2])


def test_design_starts_and_ends_at_rest_within_limits(design):
    rec = design.to_recording(dt=1e-3)
    q = rec.select(["r1", "r2", "r3", "r4"])
    qd = rec.select(["rd1", "rd2", "rd3", "rd4"])
    qdd = rec.select(["rdd1", "rdd2", "rdd3", "rdd4"])
    for row in (0, -1):
        np.testing.assert_allclose(qd[row], 0.0, atol=1e-9)
        np.testing.assert_allclose(qdd[row], 0.0, atol=1e-9)
    np.testing.assert_allclose(q[0], q[-1], atol=1e-9)
    assert np.all(np.abs(qd) <= 2.0 * (1 + 1e-9))
    assert np.all(np.abs(qdd) <= 8.0 * (1 + 1e-9))
    assert np.all(np.abs(q) <= np.pi)


def test_design_beats_the_random_trajectories(design):
    assert design.condition_number <= design.random_condition_numbers.min()
    assert design.improvement >= 1.0
    assert "random trajectories" in design.summary()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"position": [[1.0, -1.0]] * 4}, r"position limits of joint 1.*lower"),
        ({"velocity": 0.0}, r"velocity limit of joint 1 is 0"),
        ({"acceleration": [1.0, 1.0, -1.0, 1.0]}, r"acceleration limit of joint 3"),
    ],
)
def test_limits_that_cannot_be_met(arm, kwargs, match):
    with pytest.raises(InputError, match=match):
        excitation_limits(arm, **kwargs)


def test_start_outside_the_limits_is_refused(arm):
    with pytest.raises(InputError, match="q_start of joint 2"):
        design_excitation(arm, q_start=[0.0, 5.0, 0.0, 0.0], n_random=1, max_iter=1)


def test_cli_writes_a_reference_recording(tmp_path, capsys):
    out = tmp_path / "traj.csv"
    code = main(
        [
            "design-excitation",
            "manipulator",
            "--harmonics",
            "2",
            "--period",
            "2",
            "--velocity",
            "1.5",
            "--random",
            "3",
            "--max-iter",
            "2",
            "--out",
            str(out),
            "--json",
        ]
    )
    payload = json.loads(capsys.readouterr().out)
    assert code == 0
    assert payload["condition_number"] <= payload["random_median_condition_number"]
    rec = physid.load_recording(out)
    assert {"r1", "r4", "rd1", "rdd4"} <= set(rec.names)
    assert rec.t[-1] == pytest.approx(2.0)


def test_design_excitation_refuses_a_huge_grid_before_allocating(tmp_path, capsys):
    from physid.cli import main

    out = tmp_path / "x.csv"
    argv = ["design-excitation", "tests/data/planar2.urdf", "--harmonics", "2", "--period"]
    assert main([*argv, "1e12", "--out", str(out)]) == 2
    assert "asks for 1e+15 samples; at most 5e7" in capsys.readouterr().err
    assert not out.exists()
