"""The optimised excitation design (SLSQP) on the 2-link planar URDF: its limits, its two random
baselines and the condition-number definition (fixed seeds, numbers asserted)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import physid
from _helpers import DATA
from physid.analysis import excitation as ex
from physid.analysis.excitation import design_excitation, fourier_trajectory
from physid.cli import main
from physid.estimators.idim import base_regressor_info, condition_number

V, A = 2.0, 8.0  # rad/s, rad/s²


@pytest.fixture(scope="module")
def design(planar):
    return design_excitation(
        planar, harmonics=3, period=4.0, velocity=V, acceleration=A, n_random=10, n_starts=2
    )


def test_designed_trajectory_respects_every_limit_and_rests_at_both_ends(planar, design):
    rec = design.to_recording(dt=1e-4)  # 40 001 samples: far finer than the check grid
    q = rec.select(["r1", "r2"])
    qd = rec.select(["rd1", "rd2"])
    qdd = rec.select(["rdd1", "rdd2"])
    pos = np.asarray(planar.limits["position"])
    assert np.all(q.min(axis=0) >= pos[:, 0]) and np.all(q.max(axis=0) <= pos[:, 1])
    assert np.abs(qd).max() <= V and np.abs(qdd).max() <= A
    for row in (0, -1):
        np.testing.assert_allclose(qd[row], 0.0, atol=1e-9)
        np.testing.assert_allclose(qdd[row], 0.0, atol=1e-9)
    np.testing.assert_allclose(q[-1], q[0], atol=1e-9)
    np.testing.assert_allclose(q[0], design.q_start, atol=1e-12)
    # the design uses the range it has: the velocity limit binds on both joints (within 3 %)
    assert np.all(design.peak["velocity"] >= 0.95 * V)
    np.testing.assert_allclose(design.peak["velocity"], np.abs(qd).max(axis=0), rtol=1e-3)


def test_design_beats_both_random_baselines_by_stated_factors(design):
    # measured (seed 0): designed 2.35, scaled-to-the-limits median 5.88, within-limits 7.68
    assert design.condition_number == pytest.approx(2.35, rel=0.05)
    assert design.improvement >= 2.0
    assert design.improvement_within >= 2.5
    assert design.random_within_median >= design.random_median
    assert design.condition_number <= design.random_condition_numbers.min()
    assert len(design.starts) == 2 and min(design.starts) < 1.05 * design.condition_number
    text = design.summary()
    assert "scaled to the same limits" in text and "within the limits" in text


def test_condition_number_is_the_column_scaled_base_regressor_on_the_check_grid(planar, design):
    t = np.linspace(0.0, design.period, design.n_check, endpoint=False)
    q, qd, qdd = design.trajectory(t)
    cols = base_regressor_info(planar).columns
    W = np.asarray(planar.regressor(q, qd, qdd))[:, :, cols]
    # independent: an SVD of the stacked, column-scaled base regressor (idim's definition)
    assert design.condition_number == pytest.approx(condition_number(W), rel=1e-7)
    # the unscaled number is the plain SVD ratio (unit-dependent: reported, not optimised)
    s = np.linalg.svd(W.reshape(-1, W.shape[-1]), compute_uv=False)
    assert design.unscaled["designed"] == pytest.approx(s[0] / s[-1], rel=1e-9)


def test_random_baselines_are_what_their_names_say(planar, design):
    """Scaled: each joint touches (98 % of) its tightest limit; within: a fraction of that."""
    rng = np.random.default_rng(0)
    lim = ex.excitation_limits(planar, velocity=V, acceleration=A)
    fine = np.linspace(0.0, 4.0, 20 * 48, endpoint=False)
    check = np.linspace(0.0, 4.0, design.n_check, endpoint=False)
    cols = base_regressor_info(planar).columns
    free = rng.normal(size=2 * 2 * 2)
    c, *_ = ex._scaled(free, 2, 3, 4.0, fine, np.zeros(2), lim)  # the baselines start at 0
    q, qd, qdd = fourier_trajectory(c, fine, 4.0, np.zeros(2))
    use = np.maximum.reduce(
        [np.abs(qd).max(axis=0) / V, np.abs(qdd).max(axis=0) / A]
    )  # position limits are far (±3, ±2.5 rad)
    np.testing.assert_allclose(use, ex.MARGIN, rtol=1e-12)
    q, qd, qdd = fourier_trajectory(c, check, 4.0, np.zeros(2))
    W = np.asarray(planar.regressor(q, qd, qdd))[:, :, cols]
    assert design.random_condition_numbers[0] == pytest.approx(condition_number(W), rel=1e-7)
    u = rng.uniform(0.0, 1.0, size=2)
    q, qd, qdd = fourier_trajectory(c * u[:, None, None], check, 4.0, np.zeros(2))
    W = np.asarray(planar.regressor(q, qd, qdd))[:, :, cols]
    assert design.random_within_condition_numbers[0] == pytest.approx(condition_number(W), rel=1e-7)


def test_a_binding_position_limit_and_a_fixed_start_are_honoured(planar):
    position = np.array([[-0.2, 0.3], [-0.25, 0.25]])
    given = position.copy()
    d = design_excitation(
        planar,
        harmonics=3,
        period=4.0,
        velocity=V,
        acceleration=A,
        position=position,
        q_start=[0.05, 0.0],
        n_random=4,
        n_starts=1,
    )
    np.testing.assert_array_equal(position, given)  # not mutated
    np.testing.assert_array_equal(d.q_start, [0.05, 0.0])
    t = np.linspace(0.0, 4.0, 40001)
    q, qd, qdd = d.trajectory(t)
    assert np.all(q.min(axis=0) >= position[:, 0]) and np.all(q.max(axis=0) <= position[:, 1])
    assert np.abs(qd).max() <= V and np.abs(qdd).max() <= A
    # the position range is what binds now: one joint comes within 5 % of a position limit
    reach = np.maximum((q.max(axis=0) - 0.0) / position[:, 1], q.min(axis=0) / position[:, 0])
    assert reach.max() >= 0.95
    assert d.improvement > 1.0


def test_bad_settings_name_the_python_argument(planar):
    with pytest.raises(physid.errors.InputError, match="n_starts must be a positive integer"):
        design_excitation(planar, n_starts=0)
    with pytest.raises(physid.errors.InputError, match="n_grid must be at least 4·harmonics"):
        design_excitation(planar, harmonics=3, n_grid=5)


def test_cli_prints_both_baselines(tmp_path, capsys):
    out = tmp_path / "traj.csv"
    code = main(
        [
            "design-excitation",
            str(DATA / "planar2.urdf"),
            "--harmonics",
            "3",
            "--period",
            "4",
            "--velocity",
            "2",
            "--acceleration",
            "8",
            "--random",
            "6",
            "--starts",
            "1",
            "--out",
            str(out),
            "--json",
        ]
    )
    captured = capsys.readouterr()
    payload = json.loads(captured.out)
    assert code == 0
    assert payload["condition_number"] < payload["random_median_condition_number"]
    assert payload["improvement"] == pytest.approx(
        payload["random_median_condition_number"] / payload["condition_number"]
    )
    assert payload["random_within_median_condition_number"] > payload["condition_number"]
    assert len(payload["random_condition_numbers"]) == 6 and len(payload["starts"]) == 1
    code = main(
        ["design-excitation", str(DATA / "planar2.urdf"), "--harmonics", "2", "--period", "2"]
        + ["--random", "3", "--starts", "1", "--max-iter", "5", "--out", str(tmp_path / "b.csv")]
    )
    err = capsys.readouterr().err
    assert code == 0
    assert "random trajectories scaled to the same limits" in err and "within the limits" in err


def test_an_optimised_rest_position_stays_inside_the_limits(planar):
    position = np.array([[-0.2, 0.3], [-0.25, 0.25]])
    d = design_excitation(
        planar,
        harmonics=3,
        period=4.0,
        velocity=V,
        acceleration=A,
        position=position,
        q_start="optimise",
        n_random=4,
        n_starts=1,
    )
    q, qd, qdd = d.trajectory(np.linspace(0.0, 4.0, 40001))
    assert np.all(q.min(axis=0) >= position[:, 0]) and np.all(q.max(axis=0) <= position[:, 1])
    assert np.abs(qd).max() <= V and np.abs(qdd).max() <= A
    np.testing.assert_allclose(q[0], d.q_start, atol=1e-12)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-9)
    assert np.all(d.q_start > position[:, 0]) and np.all(d.q_start < position[:, 1])
    assert np.any(np.abs(d.q_start) > 1e-3)  # it moved
    with pytest.raises(physid.errors.InputError, match="q_start must be None, 'optimise'"):
        design_excitation(planar, q_start="best")
