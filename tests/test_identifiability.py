"""Structural and numerical identifiability (physid.analysis.identifiability)."""

from __future__ import annotations

import numpy as np
import pytest

import physid
from physid.analysis.identifiability import (
    IdentifiabilityWarning,
    describe_direction,
    hold_plan,
    numeric_identifiability,
    raise_if_not_excited,
    structural_identifiability,
)
from physid.errors import IdentifiabilityError, InputError


@pytest.fixture(scope="module", params=["exact", "paper"])
def arm(request):
    return physid.load_model("manipulator", kinetic=request.param)


class TwoCombinations:
    """τ = a·b²·q̈ + c·d·q̇ + e·sin q: a,b enter as a*b**2, c,d as c*d; e alone (hand-made model)."""

    parameter_names = ("a", "b", "c", "d", "e")
    parameters = {"a": 2.0, "b": 0.5, "c": 3.0, "d": 1.5, "e": 0.7}
    n_joints = 1
    beta_names = ("a*b**2", "c*d", "e")

    def parameter_jacobian(self, q, qd, qdd, params=None):
        p = dict(self.parameters, **(params or {}))
        a, b, c, d = p["a"], p["b"], p["c"], p["d"]
        cols = [b**2 * qdd, 2 * a * b * qdd, d * qd, c * qd, np.sin(q)]
        return np.stack(cols, axis=-1)  # (n, 1, 5)


# ---------------------------------------------------------------------- structural, paper's arm
def test_arm_m1_l1_enter_only_as_product(arm):
    s = structural_identifiability(arm)
    assert s.expressions == ["m1*l1**2"]
    assert s.texts == ["m1 and l1 enter only as m1*l1**2"]
    assert s.identifiable == ("m2", "m3", "m4", "l2", "l3", "l4")
    assert s.not_excitable == ()
    # the invisible direction in δθ/θ is exactly (2, -1)/√5 on (m1, l1): m1·l1² is unchanged
    d = s.combinations[0].direction
    assert d["m1"] == pytest.approx(2 / np.sqrt(5), abs=1e-9)
    assert d["l1"] == pytest.approx(-1 / np.sqrt(5), abs=1e-9)
    # one zero singular value (round-off), the next one far above it
    assert s.singular_values[-1] < 1e-12 < 1e-4 < s.singular_values[-2]


def test_arm_agrees_with_models_base_parameters(arm):
    """Independent route: the models' QR on the regressor gives θ-rank 7 and names m1*l1**2."""
    s = structural_identifiability(arm)
    base = arm.base_parameters()
    assert base.theta_rank == len(arm.parameter_names) - len(s.combinations) == 7
    assert any("m1*l1**2" in text for text in base.unidentifiable)


def test_arm_answer_does_not_depend_on_parameters_or_seed(arm):
    other = {"m1": 3.0, "m2": 7.0, "l1": 1.3, "l3": 0.1}
    assert structural_identifiability(arm, other, seed=5).expressions == ["m1*l1**2"]


# ---------------------------------------------------------------------- structural, hand-made model
def test_two_combinations_found_and_named():
    s = structural_identifiability(TwoCombinations())
    assert sorted(s.expressions) == ["a*b**2", "c*d"]
    assert "c and d enter only as c*d" in s.texts
    assert s.identifiable == ("e",)


def test_describe_direction_uses_beta_names_for_three_parameters():
    # v = (1, 1, -2) leaves a*b*c unchanged: exponents (1, 1, 1) give 1 + 1 - 2 = 0
    c = describe_direction([1.0, 1.0, -2.0], ["a", "b", "c"], beta_names=["a*b", "a*b*c", "c"])
    assert c.expression == "a*b*c"
    assert c.text == "a, b and c enter only as a*b*c"


def test_describe_direction_generic_text_when_no_monomial_fits():
    c = describe_direction([1.0, 1.0], ["a", "b"])  # invariant a/b is not a positive monomial
    assert c.expression == "combination of a and b"
    assert "not separately identifiable" in c.text


def test_describe_direction_checks_shape():
    with pytest.raises(InputError, match="one entry per name"):
        describe_direction([1.0, 2.0, 3.0], ["a", "b"])


# ---------------------------------------------------------------------- hold plan
def test_hold_plan_holds_last_of_each_combination_with_warning(arm):
    s = structural_identifiability(arm)
    initial = dict(arm.parameters, l1=0.41)
    with pytest.warns(
        IdentifiabilityWarning, match=r"m1\*l1\*\*2.*l1 is held at its initial value 0\.41"
    ):
        plan = hold_plan(s, initial)
    assert plan == {"l1": 0.41}


def test_hold_plan_user_fix_resolves_combination(arm, recwarn):
    s = structural_identifiability(arm)
    plan = hold_plan(s, arm.parameters, {"m1": 50.0})
    assert plan == {"m1": 50.0}
    assert not [w for w in recwarn if issubclass(w.category, IdentifiabilityWarning)]


def test_hold_plan_rejects_unknown_name(arm):
    with pytest.raises(InputError, match=r"unknown parameter\(s\) \['mass1'\]"):
        hold_plan(structural_identifiability(arm), arm.parameters, {"mass1": 1.0})


# ---------------------------------------------------------------------- numeric
def test_numeric_full_rank_reports_condition_number():
    rng = np.random.default_rng(1)
    jac = rng.normal(size=(200, 3))
    n = numeric_identifiability(jac, ["x", "y", "z"])
    s = np.linalg.svd(jac, compute_uv=False)
    assert n.ok
    assert n.condition_number == pytest.approx(s[0] / s[-1], rel=1e-12)
    assert n.singular_values[0] == 1.0


def test_numeric_names_collinear_columns_in_relative_terms():
    """Columns scaled by θ: ∂/∂m = l² u and ∂/∂l = 2 m l u are collinear -> m*l**2."""
    rng = np.random.default_rng(2)
    u = rng.normal(size=100)
    m, l = 3.0, 0.5
    jac = np.column_stack([l**2 * u, 2 * m * l * u, rng.normal(size=100)])
    n = numeric_identifiability(jac, ["m", "l", "k"], scale=[m, l, 1.0])
    assert [c.expression for c in n.weak_directions] == ["m*l**2"]
    with pytest.raises(IdentifiabilityError, match=r"m and l enter only as m\*l\*\*2.*fixed=\{'l'"):
        raise_if_not_excited(n, "test")


def test_numeric_zero_column_is_not_excited():
    jac = np.column_stack([np.ones(10), np.zeros(10), np.arange(10.0)])
    n = numeric_identifiability(jac, ["a", "b", "c"])
    assert n.not_excited == ("b",)
    with pytest.raises(IdentifiabilityError, match="do not excite b at all"):
        raise_if_not_excited(n, "at the initial values")


def test_numeric_shape_error():
    with pytest.raises(InputError, match="one column per name"):
        numeric_identifiability(np.ones((5, 2)), ["a", "b", "c"])
