"""physid.errors: library errors name Python arguments, the CLI shows flags."""

from __future__ import annotations

import ast
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

import physid
from physid._validate import check_int, parameter_vector, per_joint
from physid.cli import main
from physid.errors import IdentifiabilityError, InputError, PhysidError, ShapeError, arg
from physid.estimators import InputErrorEstimator
from physid.signals import Recording, save_recording
from physid.simulate.closed_loop import closed_loop_rhs
from physid.simulate.pd import pd_rhs

SRC = Path(physid.__file__).resolve().parent


def _still_arm(n=500):
    """A 4-joint record at rest (q, r, tau) at 1 kHz: enough for the argument checks."""
    t = np.arange(n) * 1e-3
    names = [f"{k}{j}" for k in ("q", "r", "tau") for j in range(1, 5)]
    return Recording(t, np.zeros((n, 12)), names)


FLAG = re.compile(r"(?<![\w-])--[a-z]")


def test_marked_argument_renders_as_keyword_or_flag():
    e = InputError(
        f"{arg('kp')} must be positive; pass {arg('kp', '[...]', cli='a,b,...')} or "
        f"{arg('resample', 'True', cli='')}."
    )
    assert str(e) == "kp must be positive; pass kp=[...] or resample=True."
    assert e.render({"kp": "--kp", "resample": "--resample"}) == (
        "--kp must be positive; pass --kp a,b,... or --resample."
    )
    # a keyword without a flag keeps its Python spelling; no mapping gives str(e)
    assert (
        e.render({"kp": "--gain"})
        == "--gain must be positive; pass --gain a,b,... or resample=True."
    )
    assert e.render() == str(e)
    assert e.arguments == ("kp", "resample")
    assert "\x1e" not in str(e) and "\x1e" not in repr(e)


def test_unmarked_message_and_extra_arguments():
    e = ShapeError("plain text", arguments=("x",))
    assert str(e) == "plain text" == e.render({"x": "--x"}) == e.template
    assert e.arguments == ("x",)
    assert isinstance(PhysidError(), Exception) and str(PhysidError()) == ""


def test_errors_survive_pickling_with_their_marks():
    e = IdentifiabilityError(f"hold one: {arg('fixed', '{NAME: VALUE}', cli='NAME=VALUE')}")
    back = pickle.loads(pickle.dumps(e))
    assert type(back) is IdentifiabilityError and str(back) == str(e)
    assert back.render({"fixed": "--fix"}) == "hold one: --fix NAME=VALUE"
    assert back.arguments == ("fixed",)


def test_arg_refuses_mark_characters():
    with pytest.raises(ValueError, match="must not contain"):
        arg("a\x1eb")


def test_validate_helpers_mark_their_argument():
    with pytest.raises(InputError) as info:
        check_int(2.0, "max_nfev", minimum=1)
    assert str(info.value).startswith("max_nfev must be an integer >= 1; got 2.0 of type float")
    assert "Pass 2 (an int, not a float)" in str(info.value)
    assert info.value.render({"max_nfev": "--max-nfev"}).startswith("--max-nfev must be")
    with pytest.raises(ShapeError) as info:
        per_joint([1.0, 2.0], "kd", 3)
    assert info.value.arguments == ("kd",)


@pytest.mark.parametrize(
    ("bad", "cls"),
    [
        ([1.0, 2.0], ShapeError),  # wrong length
        ([1.0, np.nan, 1.0, 1.0], InputError),  # non-finite
        ({"kp1": 1.0}, InputError),  # a mapping that misses joints
        ("fast", InputError),  # not numeric
    ],
)
def test_gains_raise_one_class_from_every_entry_point(bad, cls):
    """kp checked by the closed-loop simulator, the PD right-hand side and the estimator alike."""
    model = physid.load_model("manipulator")
    good = [1.0, 1.0, 1.0, 1.0]
    with pytest.raises(cls, match="kp"):
        closed_loop_rhs(model, kp=bad, kd=good, reference=lambda t: np.zeros(4))
    with pytest.raises(cls, match="kp"):
        pd_rhs(model, kp=bad, kd=good, reference=np.zeros(4))
    rec = _still_arm()
    with pytest.raises(cls, match="kp"):
        InputErrorEstimator(model, torque="pd", kp=bad, kd=good).fit(rec)


def test_pd_torque_refuses_a_log_with_feed_forward():
    """torque="pd" rebuilds Kp (r - q) - Kd q̇: on a log whose controller added g(q) that
    torque is wrong, so the estimator refuses instead of fitting it."""
    model = physid.load_model("manipulator")
    rest = _still_arm()
    rec = Recording(rest.t, rest.data, rest.names, metadata={"feedforward": "gravity"})
    est = InputErrorEstimator(model, torque="pd", kp=[1.0] * 4, kd=[1.0] * 4)
    with pytest.raises(InputError, match=r"feed-forward \(metadata feedforward = 'gravity'\)"):
        est.fit(rec)


def test_parameter_resolution_is_shared_by_both_model_kinds():
    chain = physid.load_model("manipulator")
    msd = physid.load_model("msd")
    for model, resolve in ((chain, chain.parameter_vector), (msd, msd.parameter_values)):
        with pytest.raises(InputError, match=r"params has unknown name\(s\) \['nope'\]"):
            resolve({"nope": 1.0})
        with pytest.raises(ShapeError, match="params as an array must have"):
            resolve([1.0])
        with pytest.raises(InputError, match="params must be finite"):
            resolve({model.parameter_names[0]: np.inf})
    assert parameter_vector(None, ["a"], [2.0]).tolist() == [2.0]


def _library_strings():
    """(file, line, text) of every non-docstring string literal in the library stages."""
    for folder in ("estimators", "models", "simulate", "filters", "signals", "analysis"):
        for path in sorted((SRC / folder).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            docstrings = set()
            for node in ast.walk(tree):
                if isinstance(
                    node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)
                ):
                    body = node.body
                    if (
                        body
                        and isinstance(body[0], ast.Expr)
                        and isinstance(body[0].value, ast.Constant)
                    ):
                        docstrings.add(id(body[0].value))
            for node in ast.walk(tree):
                if (
                    isinstance(node, ast.Constant)
                    and isinstance(node.value, str)
                    and id(node) not in docstrings
                ):
                    yield path.relative_to(SRC), node.lineno, node.value


def test_library_messages_name_no_command_line_flag():
    """A Python user never reads a flag: library text names keywords (marked with errors.arg)."""
    offenders = [
        f"{p}:{line}: {text!r}" for p, line, text in _library_strings() if FLAG.search(text)
    ]
    assert not offenders, "\n".join(offenders)


@pytest.fixture(scope="module")
def arm_csv(tmp_path_factory):
    rec = _still_arm()
    path = tmp_path_factory.mktemp("errors") / "arm.csv"
    save_recording(rec, path)
    return path


def test_python_user_reads_keywords(arm_csv):
    rec = physid.load_recording(arm_csv)
    model = physid.load_model("manipulator")
    with pytest.raises(InputError) as info:
        InputErrorEstimator(model, kp=[1.0, 2.0, 3.0, 4.0]).fit(rec)
    text = str(info.value)
    assert "kp/kd are used only with torque='pd'" in text and not FLAG.search(text)


def test_cli_user_reads_flags(arm_csv, capsys):
    code = main(["identify", str(arm_csv), "--model", "manipulator", "--kp", "1,2,3,4"])
    err = capsys.readouterr().err
    assert code == 2
    assert (
        "physid: error: --kp/--kd are used only with --torque pd; got --kp with --torque measured"
        in err
    )
    assert "torque=" not in err and "kp=" not in err
    code = main(["identify", str(arm_csv), "--model", "manipulator", "--half-width", "0"])
    err = capsys.readouterr().err
    assert code == 2 and "physid: error: --half-width must be an integer >= 1; got 0" in err


def test_warning_names_python_argument_in_python_and_flag_on_the_cli(tmp_path, capsys):
    from physid.cli import main
    from physid.errors import PhysidWarning
    from physid.models.identifiability import (
        IdentifiabilityWarning,
        hold_plan,
        structural_identifiability,
    )
    from physid.signals import save_recording
    from physid.simulate.closed_loop import paper_manipulator_experiment

    arm = physid.load_model("manipulator")
    with pytest.warns(IdentifiabilityWarning) as record:
        hold_plan(structural_identifiability(arm), dict(arm.parameters, l1=0.41))
    (w,) = record.list
    assert isinstance(w.message, PhysidWarning)
    assert "Pass fixed={'l1': VALUE} with a measured value" in str(w.message)  # Python words

    path = tmp_path / "arm.csv"
    save_recording(paper_manipulator_experiment(kinetic="paper"), path)
    argv = ["identify", str(path), "--model", "manipulator", "--kinetic", "paper"]
    argv += ["--torque", "pd", "--half-width", "100", "--cutoff", "0.2", "--json"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if "m1*l1**2" in x and "warning" in x)
    assert line.startswith("physid: warning: m1 and l1 enter only as m1*l1**2")
    assert "Pass --fix l1=VALUE with a measured value" in line  # the verb's flag
    assert "fixed=" not in err and "\x1e" not in err
