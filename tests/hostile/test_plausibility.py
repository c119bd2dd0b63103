"""The plausibility gate before ``success``: data that cannot support a fit never report success.

Each case fails on an estimator that trusts its solver alone: a joint that never moves
(input-error), all-zero torques (IDIM), an input whose sign flips during the record (algebraic
and RLS).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import physid
from physid import Recording
from physid.estimators import make
from physid.estimators.plausibility import (
    constant_channels,
    flipped_segments,
    gate,
    partial_segments,
    still_joints,
    too_perfect,
)
from physid.simulate.msd import msd_paper_scenario

_PLANAR = "examples/models/planar2.toml"


def _planar_record(still_second: bool, zero_tau: bool = False, seed: int = 0) -> Recording:
    """A planar2 run: joint 1 (and joint 2 unless ``still_second``) moves; exact torques."""
    model = physid.load_model(_PLANAR)
    t = np.arange(0, 6, 2e-3)
    w = 2 * np.pi * np.array([0.3, 0.7, 1.1])
    q1 = 0.8 * np.sin(w[0] * t) + 0.4 * np.sin(w[2] * t)
    q2 = np.zeros_like(t) if still_second else 0.6 * np.sin(w[1] * t + 0.3)
    q = np.c_[q1, q2]
    qd = np.gradient(q, t, axis=0, edge_order=2)
    qdd = np.gradient(qd, t, axis=0, edge_order=2)
    tau = np.asarray(model.inverse_dynamics(q, qd, qdd))
    if zero_tau:
        tau = np.zeros_like(tau)
    qm = q + 1e-4 * np.random.default_rng(seed).normal(size=q.shape)
    return Recording(t, np.c_[qm, tau], ["q1", "q2", "tau1", "tau2"], ["rad", "rad", "N*m", "N*m"])


@pytest.mark.filterwarnings("ignore:the filtered equations")
def test_input_error_refuses_a_joint_that_never_moves():
    model = physid.load_model(_PLANAR)
    res = make("input-error", model).fit(_planar_record(still_second=True)).result_
    assert res.success is False
    assert re.search(r"joint 2 never moves", res.message)
    # the parameters acting only through joint 2's motion are named
    assert re.search(r"never moves .*(armature|Ia|Fv|viscous)", res.message)


@pytest.mark.filterwarnings("ignore:the filtered equations")
def test_input_error_still_succeeds_when_every_joint_moves():
    model = physid.load_model(_PLANAR)
    res = make("input-error", model).fit(_planar_record(still_second=False)).result_
    assert "never moves" not in res.message


def test_idim_refuses_all_zero_torques():
    model = physid.load_model(_PLANAR)
    res = make("idim-ols", model).fit(_planar_record(False, zero_tau=True)).result_
    assert res.success is False
    assert re.search(r"torque tau1, tau2 never change", res.message)


def _flipped_input() -> Recording:
    rec = msd_paper_scenario(1.0, 60, duration=2.0, seed=1)
    d = np.array(rec.data)
    n = d.shape[0]
    d[n // 2 :, rec.names.index("u")] *= -1.0  # the actuator's sign flips halfway
    return Recording(rec.t, d, rec.names, rec.units)


def _flipped_output() -> Recording:
    rec = msd_paper_scenario(1.0, 60, duration=2.0, seed=1)
    d = np.array(rec.data)
    n = d.shape[0]
    d[n // 2 :, rec.names.index("x")] *= -1.0  # the sensor's sign flips halfway
    return Recording(rec.t, d, rec.names, rec.units)


@pytest.mark.parametrize("method", ["algebraic", "rls"])
def test_linear_ode_estimators_refuse_an_output_sign_flip(method):
    res = make(method, "msd").fit(_flipped_output()).result_
    assert res.success is False
    assert re.search(r"Implausible: .*not during|explains almost nothing", res.message)


@pytest.mark.parametrize("method", ["algebraic", "rls"])
def test_linear_ode_estimators_refuse_a_sign_flip(method):
    res = make(method, "msd").fit(_flipped_input()).result_
    assert res.success is False
    assert re.search(r"mirror image", res.message)


@pytest.mark.parametrize("method", ["algebraic", "rls"])
def test_linear_ode_estimators_accept_the_clean_record(method):
    res = make(method, "msd").fit(msd_paper_scenario(1.0, 60, duration=2.0, seed=1)).result_
    assert res.success is True
    assert res.parameters["theta2"] == pytest.approx(133.33, rel=0.01)


def test_cli_input_error_and_algebraic_exit_1(hostile, tmp_path):
    from physid.signals import save_recording

    from ._cases import check_case

    hostile.add_file("flip_csv", save_recording(_flipped_input(), tmp_path / "flip.csv"))
    check_case(hostile, ["estimate", "{flip_csv}", "--method", "algebraic"], 1, r"mirror image")


# the checks on their own --------------------------------------------------------------------


def test_constant_channels_and_too_perfect():
    y = np.c_[np.zeros(100), np.linspace(0, 1, 100), np.full(100, 3.0)]
    assert constant_channels(y, ["a", "b", "c"]) == ["a", "c"]
    assert too_perfect(np.zeros_like(y), y, ["a", "b", "c"]) is not None
    assert too_perfect(1e-3 * np.ones_like(y), y, ["a", "b", "c"]) is None
    moving = np.c_[np.sin(np.linspace(0, 9, 100))]
    assert too_perfect(np.zeros_like(moving), moving, ["x"]) is None


def test_still_joints_against_the_noise_floor():
    rng = np.random.default_rng(2)
    t = np.linspace(0, 5, 5001)
    q = np.c_[np.sin(t), 3e-4 * np.sin(40 * t), np.zeros_like(t)]
    q = q + 1e-4 * rng.normal(size=q.shape)
    # 3e-4 rad of motion is 2 σ of the noise: indistinguishable from it; joint 3 holds still
    assert still_joints(q) == [1, 2]
    assert (
        still_joints(np.c_[np.sin(t), 0.01 * np.sin(3 * t)] + 1e-4 * rng.normal(size=(5001, 2)))
        == []
    )


def test_flipped_segments_and_gate():
    t = np.linspace(0, 4, 4000)
    y = np.sin(7 * t)
    assert flipped_segments(t, y, y) is None
    flipped = np.where(t < 2, y, -y)
    text = flipped_segments(t, flipped, y)
    assert text is not None and "mirror image" in text
    assert gate(True, "ok.", [None]) == (True, "ok.")
    assert gate(True, "ok.", ["bad."]) == (False, "Implausible: bad. ok.")


def test_residual_analysis_is_not_white_on_nan():
    from physid.analysis.validation import residual_analysis

    e = np.full(500, np.nan)
    r = residual_analysis(e, np.sin(np.arange(500.0)))
    assert r["white"] is False and r["independent"] is False
    assert re.search(r"not finite at 500 of 500 samples", r["verdict"])
    assert "explains the data" not in r["verdict"].replace("nothing says the model explains", "")
    zero = residual_analysis(np.zeros(500))
    assert zero["white"] is False and "constant" in zero["verdict"]


def test_huge_values_are_refused_not_a_traceback(hostile, tmp_path):
    from physid.signals import save_recording

    from ._cases import check_case

    rec = msd_paper_scenario(1.0, 60, duration=2.0, seed=1)
    big = Recording(rec.t, np.asarray(rec.data) * 1e140, rec.names, rec.units)
    hostile.add_file("big_csv", save_recording(big, tmp_path / "big.csv"))
    for method in ("algebraic", "rls"):
        check_case(
            hostile,
            ["estimate", "{big_csv}", "--method", method],
            2,
            r"channel 'u' .* above 1e\+60",
        )


def test_partial_segments():
    t = np.linspace(0, 4, 4000)
    y = np.sin(7 * t)
    assert partial_segments(t, y, y) is None
    noise = np.random.default_rng(4).normal(size=t.size)
    half = np.where(t < 2, noise, y)  # the model follows only the second half
    text = partial_segments(t, half, y)
    assert text is not None and "not during 0–" in text
    # a first half at rest (a tenth of the energy or less) is not judged
    rest = np.where(t < 2, 0.01 * noise, y)
    assert partial_segments(t, rest, y) is None


def test_a_parameter_without_effect_is_not_named_under_a_still_joint():
    """Joint 2 still: Fv2 (all its Jacobian energy on joint 2) is named under it; a parameter
    whose column is zero (inert) is named once on its own, never as acting through joint 2."""
    from types import SimpleNamespace

    from physid.estimators.input_error.conclude import _implausible

    rng = np.random.default_rng(4)
    t = np.linspace(0, 5, 5001)
    q = np.c_[np.sin(t), np.zeros_like(t)] + 1e-4 * rng.normal(size=(t.size, 2))
    jac = np.zeros((t.size, 2, 3))  # (sample, joint, parameter): rows sample-major
    jac[:, :, 0] = rng.normal(size=(t.size, 2))  # "m": acts on both joints
    jac[:, 1, 1] = rng.normal(size=t.size)  # "Fv2": only on joint 2's equation
    problem = SimpleNamespace(
        free_names=["m", "Fv2", "z"], tau_f=rng.normal(size=(t.size, 2)),
        filtered=SimpleNamespace(q=q),
    )  # fmt: skip
    solution = SimpleNamespace(jacobian=jac.reshape(-1, 3), residuals=rng.normal(size=(t.size, 2)))
    still, inert, perfect = _implausible(problem, solution)
    assert re.search(
        r"^joint 2 never moves .*, so Fv2 \(which act only through its motion\)", still
    )
    assert inert.startswith("z change no torque in this record (their columns of the Jacobian")
    assert perfect is None
