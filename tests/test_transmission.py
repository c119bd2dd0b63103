"""Transmissions: gear ratios, a coupled wrist, motor-side terms and channels (models/transmission).

The independent implementation is pinocchio for the rigid bodies plus the motor terms written
from their definition in tests/_wrist_logs.py (θm = K q, τ = Kᵀ τm, rotor torques on the
motor side).
"""

import contextlib
import io
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import physid
from _wrist_logs import (
    FCM,
    FVM,
    IM,
    JOINTS,
    URDF,
    K,
    coupled,
    sidecar,
    toml_matrix,
    trajectory,
    truth_torque,
    write_log,
)
from physid.cli import main
from physid.errors import ModelFileError

pin = pytest.importorskip("pinocchio")


def test_coupled_wrist_matches_pinocchio_plus_motor_terms(tmp_path):
    """Inverse dynamics, M(q) and the regressor against the independent implementation."""
    model = physid.load_model(coupled(tmp_path, values=(IM, FVM, FCM)))
    assert model.parameter_names[-3:] == ("Im6", "Fvm6", "Fcm6")
    _, q, qd, qdd = trajectory(3, T=0.5)
    tau = model.inverse_dynamics(q, qd, qdd)
    truth = truth_torque(q, qd, qdd)
    assert np.max(np.abs(tau - truth)) < 1e-10 * np.max(np.abs(truth))
    Y = model.regressor(q, qd, qdd)
    assert np.max(np.abs(Y @ model.parameter_vector() - truth)) < 1e-10 * np.max(np.abs(truth))
    pm = pin.buildModelFromUrdf(str(URDF))
    data = pm.createData()
    M = model.mass_matrix(q[:5])
    for s in range(5):
        Mp = pin.crba(pm, data, q[s])
        Mp = np.triu(Mp) + np.triu(Mp, 1).T + K.T @ np.diag(IM) @ K  # rotors: Kᵀ diag(Im) K
        assert np.max(np.abs(M[s] - Mp)) < 1e-12
    # motor 6's inertia couples joints 5 and 6 in M(q): N6² Im6 off the diagonal
    assert np.isclose(model.mass_matrix(q[:1])[0, 4, 5] - pin.crba(pm, data, q[0])[4, 5], 0.25)
    # the numpy path (no C kernel) computes the same
    from physid.models import rigid

    beta = model.parameter_vector()
    assert np.max(np.abs(rigid.rnea(model.chain, beta, q, qd, qdd) - tau)) < 1e-10
    assert np.max(np.abs(rigid.regressor(model.chain, q, qd, qdd) - Y)) < 1e-10


def test_motor_channels_become_joint_channels(tmp_path):
    """qm → q = K⁻¹ θm + q0, taum → τ = Kᵀ τm, im → τ = Kᵀ (kt ⊙ i)."""
    kt = [0.5, 0.5, 0.4, 0.3, 0.3, 0.3]
    q0 = [0.0, -1.5, 1.5, 0.0, 0.0, 0.0]
    extra = f"joint_offsets = {q0}\ntorque_constants = {kt}\n"
    model = physid.load_model(coupled(tmp_path, extra=extra))
    rng = np.random.default_rng(0)
    q = rng.normal(size=(7, 6))
    th = (q - q0) @ K.T
    cur = rng.normal(size=(7, 6))
    cols = {f"qm{k + 1}": th[:, k] for k in range(6)} | {f"im{k + 1}": cur[:, k] for k in range(6)}
    out, units = model.joint_side_channels(list(cols), cols.__getitem__)
    assert np.allclose(np.column_stack([out[f"q{j + 1}"] for j in range(6)]), q, atol=1e-13)
    tau = (cur * kt) @ K
    assert np.allclose(np.column_stack([out[f"tau{j + 1}"] for j in range(6)]), tau, atol=1e-12)
    assert units["q1"] == "rad" and units["tau6"] == "N·m"
    # q5 = θm5 / N5 and q6 = θm6 / N6 − q5: the wrist's inverse, by hand
    assert np.allclose(out["q6"], th[:, 5] / 50 - th[:, 4] / 60)
    with pytest.raises(ModelFileError, match=r"motor channels \['qm1'\] are given but"):
        model.joint_side_channels(["qm1"], cols.__getitem__, "log.csv")
    with pytest.raises(ModelFileError, match=r"both motor-side qm1..qm6 and \['q1'\]"):
        model.joint_side_channels([*cols, "q1"], cols.__getitem__, "log.csv")


def _identify_and_validate(tmp_path, model_path, tag, status=0):
    saved = tmp_path / f"{tag}.json"
    argv = [
        "identify",
        str(tmp_path / "ident.csv"),
        "--model",
        str(model_path),
        "--method",
        "idim-wls",
        "--stick-threshold",
        "0",  # the simulation has no stiction
        "--save",
        str(saved),
    ]
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(argv) == status  # 1: the fit is saved but does not explain the data
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        assert main(["validate", str(saved), str(tmp_path / "held.csv"), "--json"]) == 0
    return json.loads(buf.getvalue())["relative_error"], json.loads(saved.read_text())


def test_coupled_wrist_identification_beats_the_model_without_coupling(tmp_path):
    """Held out, the coupled model's wrist torque error is >= 2× smaller than without the
    coupling terms (the same K for the channels, motor 6's terms on joint 6 alone), and the
    coupled fit recovers motor 6's inertia and friction (seeded; noise 2 mN·m motor-side)."""
    write_log(tmp_path / "ident.csv", 1, 0.002)
    write_log(tmp_path / "held.csv", 2, 0.002)
    coupled_path = coupled(tmp_path)
    # without coupling terms: τ = Kᵀ τm and q = K⁻¹ θm as above, but armature and friction per
    # joint (what a per-joint recipe can say about motor 6)
    joints = "".join(f"[joints.{j}]\narmature = 0\nviscous = 0\ncoulomb = 0\n" for j in JOINTS)
    plain = sidecar(
        tmp_path,
        "plain.toml",
        f"[transmission]\nmotor_from_joint = {toml_matrix(K)}\n{joints}",
    )
    err_c, res_c = _identify_and_validate(tmp_path, coupled_path, "coupled")
    err_p, _ = _identify_and_validate(tmp_path, plain, "plain", status=1)
    for j in ("tau5", "tau6"):
        assert err_p[j] >= 2.0 * err_c[j], (j, err_p[j], err_c[j])
    assert err_p["overall"] >= 2.0 * err_c["overall"]  # measured: 0.0543 against 0.0019
    est = res_c["parameters"]
    assert est["Im6"] == pytest.approx(1e-4, rel=0.05)
    assert est["Fvm6"] == pytest.approx(1e-3, rel=0.05)
    assert est["Fcm6"] == pytest.approx(2e-2, rel=0.05)


@pytest.mark.parametrize(
    ("body", "regex"),
    [
        (
            "[transmission]\nmotor_from_joint = [[1, 0], [0, 1]]\n",
            r"coupled\.toml \(\[transmission\]\): motor_from_joint must be 6 rows",
        ),
        (
            "[transmission]\nmotor_from_joint = "
            + toml_matrix(np.vstack([np.eye(6)[:5], np.eye(6)[4]]))
            + "\n",
            r"motor_from_joint is singular .*smallest singular value",
        ),
        (
            "[transmission]\ngear_ratios = [100, 100, 0, 60, 60, 50]\n",
            r"gear_ratios has 0 for joint\(s\) \[3\]; a gear ratio N .* must be non-zero",
        ),
        (
            "[transmission]\ngear_ratios = [1, 1, 1, 1, 1, 1]\ngear = 2\n",
            r"unknown key\(s\) \['gear'\]",
        ),
        (
            "[transmission]\ngear_ratios = [1, 1, 1, 1, 1, 1]\n[transmission.motors.motor_7]\n"
            'inertia = "Im7"\n',
            r"motor tables are named motor_1 \.\. motor_6",
        ),
        (
            "[transmission]\ngear_ratios = [1, 1, 1, 1, 1, 1]\ntorque_constants = [1, 1, 0, 1, 1, 1]\n",
            r"torque_constants has 0 for motor\(s\) \[3\]",
        ),
        (
            "[transmission]\ngear_ratios = [1, 1, 1, 1, 1, 1]\n[transmission.motors.motor_1]\n"
            'inertia = "m2"\n',
            r"parameter name\(s\) \['m2'\] used twice",
        ),
    ],
)
def test_bad_transmission_tables(tmp_path, body, regex):
    with pytest.raises(ModelFileError, match=regex):
        physid.load_model(sidecar(tmp_path, "coupled.toml", body))


def test_currents_need_torque_constants(tmp_path):
    model = physid.load_model(coupled(tmp_path))
    cols = {f"im{k + 1}": np.ones(3) for k in range(6)}
    with pytest.raises(ModelFileError, match="has no torque_constants"):
        model.joint_side_channels(list(cols), cols.__getitem__)


def test_rigid_toml_with_gear_ratios_and_diagonal_motor_terms():
    """A diagonal K: motor terms are the joint's armature N² Im and friction N² Fvm, N Fcm."""
    text = """
name = "axis"
[[joints]]
type = "revolute"
dh = { a = 0.3 }
mass = 2.0
com = [0.15, 0, 0]
[transmission]
gear_ratios = [-40]
[transmission.motors.motor_1]
inertia = 1e-4
viscous = 2e-3
coulomb = 0.01
"""
    from physid.models.library import model_from_spec
    from physid.models.spec import parse_model_text

    model = model_from_spec(parse_model_text(text, "axis.toml"))
    assert model.parameter_names[-3:] == ("Im1", "Fvm1", "Fcm1")
    q, qd, qdd = np.array([[0.3]]), np.array([[0.7]]), np.array([[-1.1]])
    tau = model.inverse_dynamics(q, qd, qdd)
    rigid_only = model.inverse_dynamics(q, qd, qdd, {"Im1": 0.0, "Fvm1": 0.0, "Fcm1": 0.0})
    # θ̇m = −40 q̇: τ = −40 (Im (−40 q̈) + Fvm (−40 q̇) + Fcm sign(−40 q̇))
    expected = 1600 * 1e-4 * -1.1 + 1600 * 2e-3 * 0.7 + 40 * 0.01 * 1.0
    assert tau[0, 0] - rigid_only[0, 0] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("kernel", ["c", "numpy"])
def test_forward_dynamics_of_a_coupled_model_inverts_inverse_dynamics(
    tmp_path, kernel, monkeypatch
):
    """make_rhs (simulation): q̈ = M⁻¹(τ − h) with the rotors' Kᵀ diag(Im) K in M."""
    values = (IM, FVM, np.zeros(6))  # no Coulomb term: sign(θ̇m) is exact here
    model = physid.load_model(coupled(tmp_path, values=values))
    if kernel == "numpy":
        monkeypatch.setattr(model, "_core_kernel", lambda: None)
    rhs = model.make_rhs()
    rng = np.random.default_rng(4)
    for _ in range(5):
        q, qd, tau = rng.normal(size=6), rng.normal(size=6), 10 * rng.normal(size=6)
        qdd = rhs(q, qd, tau)
        back = model.inverse_dynamics(q[None], qd[None], qdd[None])[0]
        assert np.max(np.abs(back - tau)) < 1e-9


def test_simulating_motor_coulomb_terms_says_how(tmp_path):
    from physid.models.urdf import ModelWarning

    model = physid.load_model(coupled(tmp_path, values=(IM, FVM, FCM)))
    with pytest.warns(
        ModelWarning, match=r"motor-side Coulomb terms \['Fcm1', .*tanh\(θ̇m / 1 rad/s\)"
    ):
        model.make_rhs()


def test_identify_from_encoder_counts_and_currents_through_the_map(tmp_path):
    """`--map qm1=enc1,…,im1=cur1,…`: the model's torque constants turn currents into torques;
    noise-free, motor 6's terms come back to 1e-3."""
    write_log(tmp_path / "log.csv", 1, 0.0)
    data = np.loadtxt(tmp_path / "log.csv", delimiter=",", skiprows=1)
    data[:, 7:] /= 2.0  # currents of motors with kt = 2 N·m/A
    head = ["time"] + [f"enc{k}" for k in range(1, 7)] + [f"cur{k}" for k in range(1, 7)]
    np.savetxt(tmp_path / "raw.csv", data, delimiter=",", header=",".join(head), comments="")
    model = coupled(tmp_path, extra="torque_constants = [2, 2, 2, 2, 2, 2]\n")
    mapping = "t=time," + ",".join(f"qm{k}=enc{k},im{k}=cur{k}" for k in range(1, 7))
    saved = tmp_path / "fit.json"
    argv = ["identify", str(tmp_path / "raw.csv"), "--model", str(model), "--map", mapping]
    argv += ["--method", "idim-ols", "--stick-threshold", "0", "--save", str(saved)]
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(argv) == 0
    est = json.loads(saved.read_text())["parameters"]
    assert est["Im6"] == pytest.approx(1e-4, rel=1e-3)
    assert est["Fvm6"] == pytest.approx(1e-3, rel=1e-3)
    assert est["Fcm6"] == pytest.approx(2e-2, rel=1e-3)


def test_gear_ratio_columns_for_either_sign_of_the_ratio():
    """Diagonal K: the columns are N² q̈, N² q̇ and |N| sign(q̇) (also for N < 0)."""
    from physid.models.transmission import Transmission

    ratios = np.array([-50.0, 80.0])
    terms = tuple((k, kind, f"{kind}{k}", 0.0) for k in range(2)
                  for kind in ("inertia", "viscous", "coulomb"))  # fmt: skip
    tr = Transmission(np.diag(ratios), np.zeros(2), terms=terms)
    rng = np.random.default_rng(3)
    qd, qdd = rng.normal(size=(9, 2)), rng.normal(size=(9, 2))
    cols = tr.columns(qd, qdd)
    for k, n in enumerate(ratios):
        other = 1 - k
        inertia, viscous, coulomb = (cols[:, :, 3 * k + c] for c in range(3))
        np.testing.assert_allclose(inertia[:, k], n**2 * qdd[:, k], rtol=1e-14)
        np.testing.assert_allclose(viscous[:, k], n**2 * qd[:, k], rtol=1e-14)
        np.testing.assert_array_equal(coulomb[:, k], abs(n) * np.sign(qd[:, k]))
        assert not np.any(cols[:, other, 3 * k : 3 * k + 3])  # a diagonal K couples nothing
    assert tr.units() == ("kg*m^2", "N*m*s/rad", "N*m") * 2


def test_currents_beside_motor_and_joint_torques_name_both_clashes(tmp_path):
    """im with taum: the message names taum (and any joint torque channel found with them)."""
    kt = [0.5, 0.5, 0.4, 0.3, 0.3, 0.3]
    model = physid.load_model(coupled(tmp_path, extra=f"torque_constants = {kt}\n"))
    cols = {f"{stem}{k + 1}": np.zeros(4) for stem in ("im", "taum") for k in range(6)}
    with pytest.raises(ModelFileError, match=r"both motor-side im1..im6 and \['taum1..'\]"):
        model.joint_side_channels(list(cols), cols.__getitem__, "log.csv")


def test_a_prismatic_axis_through_a_ball_screw_reads_in_metres_and_newtons(tmp_path):
    """A revolute-prismatic arm logged as motor angles and currents: the screw's ratio in rad/m
    gives q2 in m and tau2 in N, which `physid identify` accepts (it refused q2 "in rad"), and
    the noise-free fit recovers the arm's mass and inertia terms as from the joint-side log."""
    from physid.signals.joint_side import joint_side

    urdf = Path(__file__).parent / "data" / "arm3_prismatic.urdf"
    (tmp_path / "arm.urdf").write_text(urdf.read_text())
    ratios, kt = np.array([100.0, 2 * np.pi / 0.01, 50.0]), np.array([0.1, 0.2, 0.05])
    body = (
        'extends = "arm.urdf"\n[transmission]\n'
        f"gear_ratios = {ratios.tolist()}\ntorque_constants = {kt.tolist()}\n"
    )
    (tmp_path / "motor.toml").write_text(body)
    joint_model = physid.load_model(str(tmp_path / "arm.urdf"))
    model = physid.load_model(str(tmp_path / "motor.toml"))
    t = np.arange(0.0, 8.0, 2e-3)
    w = 2 * np.pi * np.array([[0.25, 0.4, 0.3], [0.6, 0.9, 0.7]])
    amp = np.array([[0.8, 0.08, 1.0], [0.3, 0.04, 0.5]])
    q = np.array([0.0, 0.25, 0.0]) + sum(
        a * np.sin(np.outer(t, f)) for a, f in zip(amp, w, strict=True)
    )
    qd = sum(a * f * np.cos(np.outer(t, f)) for a, f in zip(amp, w, strict=True))
    qdd = sum(-a * f**2 * np.sin(np.outer(t, f)) for a, f in zip(amp, w, strict=True))
    tau = joint_model.inverse_dynamics(q, qd, qdd)
    cols = {"t": t} | {f"qm{j + 1}": ratios[j] * q[:, j] for j in range(3)}
    cols |= {f"im{j + 1}": tau[:, j] / (ratios[j] * kt[j]) for j in range(3)}
    motor = physid.Recording.from_columns(t, {k: v for k, v in cols.items() if k != "t"})
    side = joint_side(model, motor)
    assert (side.unit("q2"), side.unit("tau2")) == ("m", "N")
    assert (side.unit("q1"), side.unit("tau3")) == ("rad", "N·m")
    np.testing.assert_allclose(side.select(["q1", "q2", "q3"]), q, atol=1e-12)
    np.testing.assert_allclose(side.select(["tau1", "tau2", "tau3"]), tau, rtol=1e-12, atol=1e-9)
    names = list(cols)
    np.savetxt(
        tmp_path / "log.csv", np.column_stack([cols[n] for n in names]), delimiter=",",
        header=",".join(names), comments="",
    )  # fmt: skip
    saved = tmp_path / "fit.json"
    argv = ["identify", str(tmp_path / "log.csv"), "--model", str(tmp_path / "motor.toml")]
    argv += ["--method", "idim-ols", "--stick-threshold", "0", "--save", str(saved)]
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        assert main(argv) == 0, err.getvalue()
    est = json.loads(saved.read_text())["parameters"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = physid.estimators.idim.IDIMEstimator(joint_model, stick_threshold=0).fit(
            physid.Recording.from_columns(t, {"q": q, "tau": tau})
        )
    for name, value in ref.result_.parameters.items():
        assert est[name] == pytest.approx(value, rel=1e-6, abs=1e-9), name
