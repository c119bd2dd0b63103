"""Hostile input for the IDIM methods and excitation design.

Each row: (case_id, argv, expected_exit, message_regex). ``{...}`` placeholders are files built
once per module by the fixture below (short closed-loop runs of the built-in 4-joint arm).
"""

from __future__ import annotations

import numpy as np
import pytest

import physid
from physid.signals import Recording, save_recording
from physid.simulate.closed_loop import simulate_closed_loop

from ._cases import case_ids, check_case

KP = "3800,40000,10000,500"
KD = "159.5,120,50,2"
W0 = 2 * np.pi * np.array([0.2, 0.3, 0.5, 0.7])

CASES = [
    (
        "idim-unexcited-column",
        ["identify", "{still}", "--model", "manipulator", "--method", "idim-ols"],
        2,
        r"nothing in the recording\(s\) excites the base parameter\(s\) .*joint",
    ),
    (
        "idim-other-joints",
        ["identify", "{good}", "{five}", "--model", "manipulator", "--method", "idim-ols"],
        2,
        r"q5",
    ),
    (
        "idim-other-period",
        ["identify", "{good}", "{slow}", "--model", "manipulator", "--method", "idim-ols"],
        2,
        r"recording 2 has sample period .* common period",
    ),
    (
        "idim-iv-without-controller",
        ["identify", "{bare}", "--model", "manipulator", "--method", "idim-iv"],
        2,
        r"IDIM-IV .* needs the controller.*--kp LIST",
    ),
    (
        "idim-decimate-too-much",
        [
            "identify",
            "{good}",
            "--model",
            "manipulator",
            "--method",
            "idim-ols",
            "--decimate",
            "400",
        ],
        2,
        r"decimate",
    ),
    (
        "idim-decimate-not-a-number",
        [
            "identify",
            "{good}",
            "--model",
            "manipulator",
            "--method",
            "idim-ols",
            "--decimate",
            "ten",
        ],
        2,
        r"--decimate expects a positive integer or auto",
    ),
    (
        "idim-consistent-needs-rigid-bodies",
        ["identify", "{good}", "--model", "manipulator", "--method", "idim-ols", "--consistent"],
        2,
        r"--consistent needs a rigid-body model",
    ),
    (
        "input-error-several-files",
        ["identify", "{good}", "{good}", "--model", "manipulator"],
        2,
        r"input-error fits one recording.*idim-ols",
    ),
    (
        "idim-poorly-conditioned-warns",
        ["identify", "{tiny}", "--model", "manipulator", "--method", "idim-ols", "--cutoff", "0.3"],
        0,
        r"condition number .*design-excitation",
    ),
    (
        "excitation-position-limits-crossed",
        [
            "design-excitation",
            "manipulator",
            "--out",
            "{tmp}/x.csv",
            "--position",
            "1,-1,-1,1,-1,1,-1,1",
        ],
        2,
        r"--position limits of joint 1 .* lower must be below the upper",
    ),
    (
        "excitation-zero-velocity",
        ["design-excitation", "manipulator", "--out", "{tmp}/x.csv", "--velocity", "1,0,1,1"],
        2,
        r"--velocity limit of joint 2 is 0",
    ),
    (
        "excitation-wrong-count",
        ["design-excitation", "manipulator", "--out", "{tmp}/x.csv", "--velocity", "1,1"],
        2,
        r"--velocity expects one value or one per joint \(4\)",
    ),
    (
        "excitation-one-harmonic",
        ["design-excitation", "manipulator", "--out", "{tmp}/x.csv", "--harmonics", "1"],
        2,
        r"harmonics must be an integer ≥ 2",
    ),
]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hostile-idim")
    arm = physid.load_model("manipulator")
    kp = [float(x) for x in KP.split(",")]
    kd = [float(x) for x in KD.split(",")]
    t = np.arange(0.0, 3.0, 1e-3)
    ramp = np.clip(t, 0.0, 1.0)[:, None] ** 3
    good = simulate_closed_loop(arm, kp=kp, kd=kd, reference=ramp * np.sin(np.outer(t, W0)), t=t)
    still = simulate_closed_loop(arm, kp=kp, kd=kd, reference=np.zeros((t.size, 4)), t=t)
    tiny = simulate_closed_loop(
        arm, kp=kp, kd=kd, reference=ramp * 0.02 * np.sin(np.outer(t, W0[[0, 0, 0, 0]])), t=t
    )
    paths = {}
    for name, rec in (("good", good), ("still", still), ("tiny", tiny)):
        paths[name] = folder / f"{name}.csv"
        save_recording(rec, paths[name])
    names = [f"q{j}" for j in range(1, 5)] + [f"tau{j}" for j in range(1, 5)]
    paths["bare"] = folder / "bare.csv"
    save_recording(Recording(good.t, good.select(names), names), paths["bare"])
    paths["slow"] = folder / "slow.csv"
    save_recording(Recording(good.t * 2, good.data, good.names), paths["slow"])
    paths["five"] = folder / "five.csv"
    save_recording(
        Recording(
            good.t,
            np.column_stack([good.data, good["q1"], good["tau1"]]),
            good.names + ("q5", "tau5"),
        ),
        paths["five"],
    )
    return paths


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_idim_input(case_id, argv, expected_exit, message_regex, files, hostile):
    for name, path in files.items():
        hostile.add_file(name, path)
    check_case(hostile, argv, expected_exit, message_regex)
