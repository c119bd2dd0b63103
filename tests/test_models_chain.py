"""Serial-chain models: cross-checks against pinocchio, hand-derived equations, invariants."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import sympy as sp

from physid.errors import InputError, ShapeError
from physid.models import dh_transform, load_model
from physid.models.chain import build_chain_model
from physid.models.lagrange import lagrange_equations
from physid.models.peers import pinocchio_model
from physid.models.spec import parse_model_text
from physid.simulate.pd import pd_rhs

G = 9.81


@pytest.fixture(scope="module")
def arm():
    return load_model("manipulator")


@pytest.fixture(scope="module")
def arm_paper():
    return load_model("manipulator", kinetic="paper")


def random_states(n, nj, seed=0):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-np.pi, np.pi, (n, nj)),
        rng.normal(0, 2, (n, nj)),
        rng.normal(0, 5, (n, nj)),
    )


def chain_from_text(text):
    return build_chain_model(parse_model_text(text, source="<test>"))


# --------------------------------------------------------------------------------- pinocchio
GENERAL_DH = """
name = "general3"
gravity = [0.3, -2.0, -9.81]
[parameters]
m1 = { value = 2.0 }
m2 = { value = 3.0 }
m3 = { value = 1.5 }
a1 = { value = 0.1 }
a2 = { value = 0.7 }
d1 = { value = 0.4 }
d3 = { value = 0.15 }
[[joints]]
dh = { a = "a1", alpha = "pi/2", d = "d1", offset = 0.3 }
mass = "m1"
rotor_inertia = 0.05
[[joints]]
dh = { a = "a2", alpha = -0.4, d = 0.05, offset = -0.2 }
mass = "m2"
rotor_inertia = "m2*a2**2/12"
[[joints]]
dh = { a = 0.3, alpha = 1.1, d = "d3", offset = 0.5 }
mass = "m3"
"""


@pytest.mark.parametrize("which", ["manipulator", "general"])
def test_exact_mode_matches_pinocchio_rnea_and_crba(arm, which):
    model = arm if which == "manipulator" else chain_from_text(GENERAL_DH)
    pm, pdata = pinocchio_model(model)
    q, qd, qdd = random_states(25, model.n_joints, seed=1)
    tau = model.inverse_dynamics(q, qd, qdd)
    M = model.mass_matrix(q)
    for i in range(q.shape[0]):
        tau_pin = pin.rnea(pm, pdata, q[i], qd[i], qdd[i])
        assert np.max(np.abs(tau[i] - tau_pin)) <= 1e-8 * np.max(np.abs(tau_pin))
        M_pin = pin.crba(pm, pdata, q[i])
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T  # crba fills the upper triangle
        assert np.max(np.abs(M[i] - M_pin)) <= 1e-8 * np.max(np.abs(M_pin))
        g_pin = pin.computeGeneralizedGravity(pm, pdata, q[i])
        np.testing.assert_allclose(
            model.gravity_forces(q[i : i + 1])[0], g_pin, rtol=1e-9, atol=1e-9
        )


def test_forward_dynamics_matches_pinocchio_aba(arm):
    pm, pdata = pinocchio_model(arm)
    q, qd, _ = random_states(20, 4, seed=2)
    tau = np.random.default_rng(3).normal(0, 50, (20, 4))
    qdd = arm.forward_dynamics(q, qd, tau)
    rhs = arm.make_rhs()
    for i in range(20):
        ref = pin.aba(pm, pdata, q[i], qd[i], tau[i])
        np.testing.assert_allclose(qdd[i], ref, rtol=1e-8, atol=1e-8 * np.abs(ref).max())
        np.testing.assert_allclose(
            rhs(q[i], qd[i], tau[i]), ref, rtol=1e-8, atol=1e-8 * np.abs(ref).max()
        )


# ------------------------------------------------------------------------ hand-derived cases
PENDULUM = """
name = "pendulum"
gravity = [0.0, -9.81, 0.0]
[parameters]
m = { value = 1.3, unit = "kg" }
l = { value = 0.7, unit = "m" }
b = { value = 0.2, unit = "N*m*s/rad" }
fc = { value = 0.4, unit = "N*m" }
[[joints]]
dh = { a = "l", alpha = 0 }
mass = "m"
viscous = "b"
coulomb = "fc"
"""


def test_pendulum_matches_hand_derived_equation():
    model = chain_from_text(PENDULUM)
    m, l, b, fc = 1.3, 0.7, 0.2, 0.4
    q, qd, qdd = random_states(30, 1, seed=4)
    # τ = m l² q̈ + m g l cos q + b q̇ + fc sign(q̇)   (p = l (cos q, sin q), V = m g l sin q)
    expected = m * l**2 * qdd + m * G * l * np.cos(q) + b * qd + fc * np.sign(qd)
    np.testing.assert_allclose(model.inverse_dynamics(q, qd, qdd), expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(model.mass_matrix(q)[:, 0, 0], m * l**2, rtol=1e-14)


DOUBLE = """
name = "double_pendulum"
gravity = [0.0, -9.81, 0.0]
[parameters]
m1 = { value = 1.0 }
m2 = { value = 0.6 }
l1 = { value = 0.9 }
l2 = { value = 0.5 }
[[joints]]
dh = { a = "l1", alpha = 0 }
mass = "m1"
[[joints]]
dh = { a = "l2", alpha = 0 }
mass = "m2"
"""


def test_double_pendulum_matches_textbook_equations():
    model = chain_from_text(DOUBLE)
    m1, m2, l1, l2 = 1.0, 0.6, 0.9, 0.5
    q, qd, qdd = random_states(30, 2, seed=5)
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    M11 = (m1 + m2) * l1**2 + m2 * l2**2 + 2 * m2 * l1 * l2 * c2
    M12 = m2 * l2**2 + m2 * l1 * l2 * c2
    M22 = m2 * l2**2
    h1 = -m2 * l1 * l2 * s2 * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2)
    h2 = m2 * l1 * l2 * s2 * qd[:, 0] ** 2
    g1 = (m1 + m2) * G * l1 * np.cos(q[:, 0]) + m2 * G * l2 * np.cos(q[:, 0] + q[:, 1])
    g2 = m2 * G * l2 * np.cos(q[:, 0] + q[:, 1])
    tau1 = M11 * qdd[:, 0] + M12 * qdd[:, 1] + h1 + g1
    tau2 = M12 * qdd[:, 0] + M22 * qdd[:, 1] + h2 + g2
    np.testing.assert_allclose(
        model.inverse_dynamics(q, qd, qdd), np.c_[tau1, tau2], rtol=1e-11, atol=1e-11
    )
    M = model.mass_matrix(q)
    np.testing.assert_allclose(M[:, 0, 0], M11, rtol=1e-13)
    np.testing.assert_allclose(M[:, 0, 1], M12, rtol=1e-13)
    np.testing.assert_allclose(model.gravity_forces(q), np.c_[g1, g2], rtol=1e-12, atol=1e-12)


def test_paper_dh_convention_reproduces_printed_transforms():
    """Cedro & Janecki, section 2: T1 = [[c,0,s,0],[s,0,-c,0],[0,1,0,0]], T2 = [[c,-s,0,lc],..]."""
    phi, l2 = sp.symbols("phi l2")
    c, s = sp.cos(phi), sp.sin(phi)
    T1 = sp.Matrix([[c, 0, s, 0], [s, 0, -c, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
    T2 = sp.Matrix([[c, -s, 0, l2 * c], [s, c, 0, l2 * s], [0, 0, 1, 0], [0, 0, 0, 1]])
    assert sp.simplify(dh_transform(0, sp.pi / 2, 0, phi) - T1) == sp.zeros(4, 4)
    assert sp.simplify(dh_transform(l2, 0, 0, phi) - T2) == sp.zeros(4, 4)


# ----------------------------------------------------------------------------- paper mode
def test_paper_mode_mass_matrix_is_diagonal_of_exact(arm, arm_paper):
    q, _, _ = random_states(20, 4, seed=6)
    Mp = arm_paper.mass_matrix(q)
    Me = arm.mass_matrix(q)
    off = Mp - np.einsum("nii->ni", Mp)[:, :, None] * np.eye(4)
    assert np.all(off == 0.0)
    np.testing.assert_allclose(np.einsum("nii->ni", Mp), np.einsum("nii->ni", Me), rtol=1e-12)
    # and the exact matrix really has coupling (so the check above can fail)
    assert np.abs(Me[:, 1, 2]).max() > 1.0


def test_paper_mode_equals_literal_euler_lagrange_of_paper_energy(arm_paper):
    """Independent derivation from the paper's energies.

    K = Σ_k ½ m_k Σ_j |∂p_k/∂q_j|² q̇_j² + Σ ½ J_k q̇_k², V = −Σ m_k g·p_k.
    """
    q = sp.symbols("q1:5")
    qd = sp.symbols("qd1:5")
    qdd = sp.symbols("qdd1:5")
    m = [50.0, 25.0, 15.0, 5.0]
    ls = [0.4, 0.8, 0.6, 0.2]
    Ts = [dh_transform(0, sp.pi / 2, 0, q[0])] + [
        dh_transform(ls[k], 0, 0, q[k]) for k in (1, 2, 3)
    ]
    T = sp.eye(4)
    K = sum(m[k] * ls[k] ** 2 / 12 * qd[k] ** 2 / 2 for k in range(4))
    V = 0
    for k in range(4):
        T = T * Ts[k]
        p = T[0:3, 3]
        K += sum(
            m[k] / 2 * sum(p[i].diff(q[j]) ** 2 for i in range(3)) * qd[j] ** 2 for j in range(4)
        )
        V += -m[k] * G * p[2]
    tau = lagrange_equations(K, V, q, qd, qdd)
    f = sp.lambdify([q, qd, qdd], list(tau), "numpy")
    qs, qds, qdds = random_states(5, 4, seed=7)
    ours = arm_paper.inverse_dynamics(qs, qds, qdds)
    for i in range(5):
        np.testing.assert_allclose(ours[i], f(qs[i], qds[i], qdds[i]), rtol=1e-10, atol=1e-9)


# --------------------------------------------------------------- Jacobian, regressor, base
@pytest.mark.parametrize("kinetic", ["exact", "paper"])
def test_parameter_jacobian_matches_finite_differences(arm, arm_paper, kinetic):
    model = arm if kinetic == "exact" else arm_paper
    q, qd, qdd = random_states(15, 4, seed=8)
    theta = model.parameter_vector() * np.linspace(0.9, 1.1, 8)
    J = model.parameter_jacobian(q, qd, qdd, theta)
    assert J.shape == (15, 4, 8)
    for j in range(8):
        h = 1e-6 * theta[j]
        tp, tm = theta.copy(), theta.copy()
        tp[j] += h
        tm[j] -= h
        fd = (model.inverse_dynamics(q, qd, qdd, tp) - model.inverse_dynamics(q, qd, qdd, tm)) / (
            2 * h
        )
        np.testing.assert_allclose(J[:, :, j], fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max() + 1e-9)


@pytest.mark.parametrize("kinetic", ["exact", "paper"])
def test_regressor_times_beta_is_inverse_dynamics(arm, arm_paper, kinetic):
    model = arm if kinetic == "exact" else arm_paper
    q, qd, qdd = random_states(40, 4, seed=9)
    params = {"m2": 23.0, "l3": 0.55, "m1": 41.0}
    Y = model.regressor(q, qd, qdd)
    assert Y.shape == (40, 4, len(model.beta_names))
    np.testing.assert_allclose(
        Y @ model.beta(params), model.inverse_dynamics(q, qd, qdd, params), rtol=1e-11, atol=1e-9
    )
    assert "m1*l1**2" in model.beta_names
    assert "m2*l2**2" in model.beta_names


def test_base_parameters_of_paper_arm(arm):
    bp = arm.base_parameters()
    # 17 monomials; (m2+m3+m4) l2, (m3+m4) l3, (m3+m4) l2², (m3+m4) l2 l3 are the dependent groups
    assert bp.n_beta == 17
    assert bp.n_base == 12
    assert bp.theta_rank == 7  # of 8: the m1/l1 direction is lost
    assert any(s.startswith("m1 and l1 enter only as m1*l1**2") for s in bp.unidentifiable)
    assert "m2*l2 + m3*l2 + m4*l2" in bp.base_names
    assert "m1*l1**2" in bp.base_names
    # the null direction is the relative change dm1/m1 = −2 dl1/l1
    v = bp.null_directions[:, 0]
    v = v / v[0]
    np.testing.assert_allclose(v, [1, 0, 0, 0, -0.5, 0, 0, 0], atol=1e-9)
    assert "m1*l1**2" in bp.summary()


def test_m1_and_l1_cannot_be_told_apart(arm):
    q, qd, qdd = random_states(30, 4, seed=10)
    tau = arm.inverse_dynamics(q, qd, qdd)
    # m1 → 2 m1 and l1 → l1/√2 keep m1 l1² (the only place either enters: J1 = m1 l1²/12)
    tau2 = arm.inverse_dynamics(q, qd, qdd, {"m1": 100.0, "l1": 0.4 / np.sqrt(2)})
    np.testing.assert_allclose(tau2, tau, rtol=1e-12, atol=1e-10)
    tau3 = arm.inverse_dynamics(q, qd, qdd, {"m1": 100.0})
    assert np.abs(tau3 - tau).max() > 1e-3


# ------------------------------------------------------------------- consistency of forms
def test_forms_are_consistent(arm):
    q, qd, qdd = random_states(30, 4, seed=11)
    tau = arm.inverse_dynamics(q, qd, qdd)
    M = arm.mass_matrix(q)
    h = arm.bias_forces(q, qd)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", M, qdd) + h, tau, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(arm.forward_dynamics(q, qd, tau), qdd, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(
        arm.bias_forces(q, 0 * qd), arm.gravity_forces(q), rtol=1e-12, atol=1e-12
    )
    assert np.all(np.linalg.eigvalsh(M) > 0)
    np.testing.assert_array_equal(M, np.swapaxes(M, 1, 2))


def test_fused_right_hand_sides(arm):
    q, qd, _ = random_states(5, 4, seed=12)
    kp = np.array([3800.0, 40000.0, 10000.0, 500.0])
    kd = np.array([159.5, 120.0, 50.0, 2.0])
    r = np.array([0.5, 0.4, 0.3, 0.2])
    state = arm.make_state_rhs({"m3": 14.0})
    pd_fun = pd_rhs(arm, {"m3": 14.0}, kp=kp, kd=kd, reference=lambda t: r * t)
    pd_const = pd_rhs(arm, {"m3": 14.0}, kp=kp, kd=kd, reference=r)
    for i in range(5):
        y = np.r_[q[i], qd[i]]
        tau = kp * (r * 2.0 - q[i]) - kd * qd[i]  # the paper's PD law at t = 2 s
        qdd = arm.forward_dynamics(q[i : i + 1], qd[i : i + 1], tau[None], {"m3": 14.0})[0]
        np.testing.assert_allclose(pd_fun(2.0, y), np.r_[qd[i], qdd], rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(state(y, tau), np.r_[qd[i], qdd], rtol=1e-10, atol=1e-9)
        tau1 = kp * (r - q[i]) - kd * qd[i]
        qdd1 = arm.forward_dynamics(q[i : i + 1], qd[i : i + 1], tau1[None], {"m3": 14.0})[0]
        np.testing.assert_allclose(
            pd_const(0.0, y.tolist()), np.r_[qd[i], qdd1], rtol=1e-10, atol=1e-9
        )


def test_paper_mode_rhs_uses_diagonal_solve(arm_paper):
    q, qd, _ = random_states(3, 4, seed=13)
    tau = np.ones((3, 4))
    M = arm_paper.mass_matrix(q)
    h = arm_paper.bias_forces(q, qd)
    f = arm_paper.make_rhs()
    for i in range(3):
        np.testing.assert_allclose(
            f(q[i], qd[i], tau[i]), (tau[i] - h[i]) / np.diag(M[i]), rtol=1e-12
        )


def test_symbolic_equations_use_readable_names(arm):
    eqs = arm.symbolic_equations()
    names = {str(s) for s in eqs.mass_matrix.free_symbols}
    assert names <= {"q1", "q2", "q3", "q4", "m1", "m2", "m3", "m4", "l1", "l2", "l3", "l4"}
    assert "m1" in {str(s) for s in eqs.mass_matrix[0, 0].free_symbols}


# --------------------------------------------------------------------------------- cache
def test_second_load_comes_from_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path))
    first = load_model("manipulator")
    second = load_model("manipulator")
    assert not first.loaded_from_cache
    assert second.loaded_from_cache
    q, qd, qdd = random_states(5, 4, seed=14)
    np.testing.assert_array_equal(
        first.inverse_dynamics(q, qd, qdd), second.inverse_dynamics(q, qd, qdd)
    )
    # a different kinetic mode is a different model: not a cache hit
    assert not load_model("manipulator", kinetic="paper").loaded_from_cache


def test_corrupt_cache_is_rebuilt(tmp_path, monkeypatch):
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path))
    load_model("manipulator")
    files = list(tmp_path.glob("chain-*.json"))
    assert len(files) == 1
    files[0].write_text('{"format": "physid-models', encoding="utf-8")  # truncated JSON
    rebuilt = load_model("manipulator")
    assert not rebuilt.loaded_from_cache
    assert load_model("manipulator").loaded_from_cache  # and the rebuilt entry is good again
    no_cache = load_model("manipulator", cache=False)
    assert not no_cache.loaded_from_cache


# ---------------------------------------------------------------------------- bad input
def test_bad_parameters_and_shapes_raise(arm):
    q, qd, qdd = random_states(3, 4)
    with pytest.raises(InputError, match=r"unknown name\(s\) \['mass1'\]"):
        arm.inverse_dynamics(q, qd, qdd, {"mass1": 3.0})
    with pytest.raises(ShapeError, match="must have 8 entries"):
        arm.inverse_dynamics(q, qd, qdd, [1.0, 2.0])
    with pytest.raises(ShapeError, match=r"qd must have 4 column"):
        arm.inverse_dynamics(q, qd[:, :3], qdd)
    with pytest.raises(ShapeError, match="qdd has 2 samples but q has 3"):
        arm.inverse_dynamics(q, qd, qdd[:2])
    with pytest.raises(InputError, match="non-finite"):
        arm.mass_matrix(np.full((2, 4), np.nan))
    with pytest.raises(InputError, match="kinetic must be 'exact' or 'paper'"):
        load_model("manipulator", kinetic="approx")
    with pytest.raises(InputError, match=r"unknown option\(s\) \['mass'\]"):
        load_model("manipulator", mass=3)
    with pytest.raises(ShapeError, match=r"kp must hold one value per joint \(4\)"):
        pd_rhs(arm, kp=[1, 2], kd=[1, 2, 3, 4], reference=[0, 0, 0, 0])


def test_inputs_are_not_mutated(arm):
    q, qd, qdd = random_states(4, 4)
    copies = [a.copy() for a in (q, qd, qdd)]
    arm.inverse_dynamics(q, qd, qdd)
    arm.forward_dynamics(q, qd, qdd)
    for a, c in zip((q, qd, qdd), copies, strict=False):
        np.testing.assert_array_equal(a, c)


def test_tree_form_fallback_matches_pinocchio(monkeypatch):
    """Long chains skip the canonical trigonometric form (CANONICAL_OPS_LIMIT); that path too."""
    from physid.models import lagrange

    monkeypatch.setattr(lagrange, "CANONICAL_OPS_LIMIT", 0)
    model = build_chain_model(parse_model_text(GENERAL_DH, source="<test>"), cache=False)
    pm, pdata = pinocchio_model(model)
    q, qd, qdd = random_states(20, 3, seed=15)
    tau = model.inverse_dynamics(q, qd, qdd)
    for i in range(20):
        tau_pin = pin.rnea(pm, pdata, q[i], qd[i], qdd[i])
        assert np.max(np.abs(tau[i] - tau_pin)) <= 1e-8 * np.max(np.abs(tau_pin))
    Y = model.regressor(q, qd, qdd)
    np.testing.assert_allclose(Y @ model.beta(), tau, rtol=1e-10, atol=1e-9)


def test_warm_load_needs_no_sympy(tmp_path, monkeypatch):
    import subprocess
    import sys

    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path))
    load_model("manipulator")  # cold: fills the cache
    code = (
        "import sys, physid\n"
        "m = physid.load_model('manipulator')\n"
        "print(m.loaded_from_cache, 'sympy' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "False"]


NON_POLYNOMIAL = """
name = "twist_parameter"
gravity = [0, 0, -9.81]
[parameters]
m1 = { value = 1.0 }
m2 = { value = 2.0 }
tw = { value = 0.7, unit = "rad" }
[[joints]]
dh = { a = 0.4, alpha = "tw" }
mass = "m1"
[[joints]]
dh = { a = 0.3, alpha = 0 }
mass = "m2"
rotor_inertia = 0.01
"""


def test_non_polynomial_model_falls_back_to_symbolic_jacobian():
    from physid.errors import IdentifiabilityError

    model = chain_from_text(NON_POLYNOMIAL)
    q, qd, qdd = random_states(10, 2, seed=16)
    with pytest.raises(IdentifiabilityError, match="not polynomial in its parameters"):
        model.regressor(q, qd, qdd)
    J = model.parameter_jacobian(q, qd, qdd)
    theta = model.parameter_vector()
    for j in range(3):
        h = 1e-6
        tp, tm = theta.copy(), theta.copy()
        tp[j] += h
        tm[j] -= h
        fd = (model.inverse_dynamics(q, qd, qdd, tp) - model.inverse_dynamics(q, qd, qdd, tm)) / (
            2 * h
        )
        np.testing.assert_allclose(J[:, :, j], fd, rtol=1e-6, atol=1e-7 * np.abs(fd).max() + 1e-9)
