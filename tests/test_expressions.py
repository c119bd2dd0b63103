"""The whitelist expression parser: what it accepts (and builds exactly as sympy's parser did),
what it refuses (with the construct named and the fix), and that no user text ever runs."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from physid import load_model
from physid.errors import ExpressionError, ModelFileError, PhysidError
from physid.expressions import (
    MAX_EXPONENT,
    MAX_LENGTH,
    MESSAGE_CLIP,
    check_real_at,
    evaluate_expression,
    expression_names,
    parse_expression,
)

m1, l1, q1 = sp.symbols("m1 l1 q1")
SYMS = {"m1": m1, "l1": l1, "q1": q1}


# ------------------------------------------------------------------ what is accepted, exactly
@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("m1*l1**2/12", m1 * l1**2 / sp.Integer(12)),
        ("pi/2", sp.pi / 2),
        ("-m1 + +l1", -m1 + l1),
        ("2/3*m1", sp.Rational(2, 3) * m1),  # exact fractions, as sympy's parser made them
        ("0.4*m1", sp.Float("0.4") * m1),
        ("l1^2", l1**2),  # ^ is a power, as with sympy's convert_xor
        ("cos(q1)*l1 + sin(q1)", sp.cos(q1) * l1 + sp.sin(q1)),
        ("atan2(q1, l1)", sp.atan2(q1, l1)),
        ("abs(m1) + Abs(l1) + sign(q1)", sp.Abs(m1) + sp.Abs(l1) + sp.sign(q1)),
        ("sqrt(m1)*exp(l1)*log(2)", sp.sqrt(m1) * sp.exp(l1) * sp.log(2)),
        ("1e-3", sp.Float("1e-3")),
        ("m1**-2", m1**-2),
        ("(((m1)))", m1),
    ],
)
def test_accepted_expressions_build_the_same_sympy_objects(text, expected):
    got = parse_expression(text, SYMS)
    assert sp.srepr(got) == sp.srepr(expected)


def test_decimal_literals_keep_the_precision_they_are_written_with():
    # sympy's auto_number made Float(str): a long literal keeps its digits (not float's 17)
    got = parse_expression("0.123456789012345678901", [])
    assert sp.srepr(got) == sp.srepr(sp.Float("0.123456789012345678901"))
    assert got._prec > 53


def test_manipulator_expressions_are_identical_to_the_sympy_parser():
    """Every expression of the built-in model file, against sympy's parser on trusted text."""
    from sympy.parsing.sympy_parser import (
        auto_number,
        auto_symbol,
        convert_xor,
        factorial_notation,
        parse_expr,
        repeated_decimals,
    )

    names = {f"{p}{k}": sp.Symbol(f"_{p}{k}") for p in "ml" for k in range(1, 5)}
    texts = ["pi/2", "0", "l2", "m1*l1**2/12", "m2*l2**2/12", "m3*l3**2/12", "m4*l4**2/12"]
    trans = (auto_symbol, repeated_decimals, auto_number, factorial_notation, convert_xor)
    for text in texts:
        reference = parse_expr(
            text,
            local_dict=dict(names),
            global_dict={
                "Integer": sp.Integer,
                "Float": sp.Float,
                "Symbol": sp.Symbol,
                "pi": sp.pi,
            },
            transformations=trans,
        )  # trusted constant text: the old path, for comparison only
        assert sp.srepr(parse_expression(text, names)) == sp.srepr(reference), text


def test_symbols_may_be_an_iterable_of_names():
    assert parse_expression("a*b", ["a", "b"]) == sp.Symbol("a") * sp.Symbol("b")


def test_functions_can_be_restricted_or_replaced():
    with pytest.raises(ExpressionError, match=r"unknown function\(s\) \['cos'\]"):
        parse_expression("cos(m1)", SYMS, functions=["sin"])
    double = parse_expression("twice(m1)", SYMS, functions={"twice": lambda x: 2 * x})
    assert double == 2 * m1


def test_expression_names():
    assert expression_names("gtau*vir + sin(q1) + pi") == (("gtau", "pi", "q1", "vir"), ("sin",))


# ------------------------------------------------------------------ what is refused, and how
@pytest.mark.parametrize(
    ("text", "reason", "pattern"),
    [
        ("'1+1'", "forbidden", r"a string literal \(quotes\) is not allowed"),
        ("foo('x')", "forbidden", r"string literal"),
        ("m1.real", "forbidden", r"an attribute access \(a\.b\) is not allowed"),
        ("m1[0]", "forbidden", r"a subscript"),
        ("(lambda: 1)()", "forbidden", r"only functions called by their bare name"),
        ("lambda: 1", "forbidden", r"a lambda"),
        ("[m1 for m1 in l1]", "forbidden", r"comprehension"),
        ("m1 < l1", "forbidden", r"a comparison"),
        ("m1 and l1", "forbidden", r"boolean operator"),
        ("m1 if l1 else 0", "forbidden", r"conditional"),
        ("m1, l1", "forbidden", r"a tuple \(a comma\)"),
        ("m1 // 2", "forbidden", r"floor division \(//\) is not allowed.*use / for division"),
        ("m1 % 2", "forbidden", r"the % operator"),
        ("not m1", "forbidden", r"the operator 'not'"),
        ("sin(x=m1)", "forbidden", r"keyword arguments in the call of 'sin'"),
        ("sin(*m1)", "forbidden", r"starred"),
        ("True", "forbidden", r"the constant True is not a number"),
        ("2j*m1", "forbidden", r"complex number"),
        ("sin", "forbidden", r"\['sin'\] used without arguments.*call it"),
        ("m1(l1)", "not_callable", r"\['m1'\] called like a function.*write \* for a product"),
        ("foo(m1)", "unknown_function", r"unknown function\(s\) \['foo'\].*allowed functions: sin"),
        ("m1 + zz", "unknown_name", r"unknown name\(s\) \['zz'\].*may appear are \['l1', 'm1'"),
        ("atan2(m1)", "arguments", r"atan2\(\) takes 2 arguments, got 1"),
        ("l1 *", "syntax", r"cannot parse the expression 'l1 \*' \(SyntaxError"),
        ("", "syntax", r"nothing to parse"),
        ("1/0", "not_finite", r"not a finite real value"),
        ("sqrt(-1)*m1", "not_finite", r"not a finite real value"),
        ("m1**99999999999", "too_large", r"exponent '99999999999' exceeds the limit of ±100"),
        ("9**9**9**9", "too_large", r"exponent '387420489' exceeds"),
        ("m1**(pi*1e9)", "too_large", r"exceeds the limit"),
        ("1" * 60, "too_large", r"integer literal with more than 50 digits"),
        ("1e400", "too_large", r"beyond the range of double precision"),
        ("sin(" * 70 + "m1" + ")" * 70, "too_large", r"nesting deeper than 60"),
        ("(" * 300 + "m1" + ")" * 300, "syntax", r"too many nested parentheses"),
        ("-" * 100 + "m1", "too_large", r"nesting deeper than 60"),
        ("+".join(["m1"] * 6000), "too_large", r"characters exceed the limit of 10000"),
        ("+".join(["a*b*c"] * 1000), "too_large", r"more than 5000 terms"),
        ("*".join(["a"] * 4000), "too_large", r"syntax tree too deep .*group terms in parentheses"),
        ("(10**50)**30", "too_large", r"exact number of about 15\d\d digits"),
    ],
)
def test_refused_constructs_name_the_construct_and_the_fix(text, reason, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse_expression(text, SYMS, source="arm.toml, line 7 (joints[1].mass)")
    assert info.value.reason == reason
    assert isinstance(info.value, PhysidError) and isinstance(info.value, ValueError)
    if reason != "syntax" or text:
        assert str(info.value).startswith("arm.toml, line 7 (joints[1].mass): ")
    # bounded messages, whatever the input's size
    assert len(str(info.value)) < 600


def test_a_20k_term_expression_gives_a_short_message():
    text = " + ".join(f"m{k}*l{k}" for k in range(20_000))
    with pytest.raises(ExpressionError) as info:
        parse_expression(text, [f"m{k}" for k in range(3)])
    assert len(str(info.value)) < 2 * MESSAGE_CLIP + 300
    assert f"{len(text)} characters" in str(info.value)


def test_many_unknown_names_are_listed_briefly():
    text = "+".join(f"z{k}" for k in range(1500))
    assert len(text) < MAX_LENGTH
    with pytest.raises(ExpressionError, match=r"and 1490 more") as info:
        parse_expression(text, ["m1"])
    assert len(info.value.names) == 1500
    assert len(str(info.value)) < 800


def test_long_flat_sums_and_products_are_fine():
    # a chain of one operator counts as one level of nesting
    assert parse_expression("+".join(["m1"] * 1000), SYMS) == 1000 * m1
    assert parse_expression("*".join(["m1"] * 50), SYMS) == m1**50
    assert MAX_EXPONENT >= 50


def test_non_string_input_is_refused():
    with pytest.raises(ExpressionError, match="must be a string"):
        parse_expression(3.0, SYMS)
    with pytest.raises(ExpressionError, match="symbols= must be a mapping"):
        parse_expression("m1", "m1")


# ------------------------------------------------------------------ no code ever runs
def test_an_undefined_function_called_with_a_string_runs_nothing(tmp_path):
    """Exploit 1 of the issue: sympy sympified the string argument of an undefined function."""
    marker = tmp_path / "pwned"
    payload = f"__import__('pathlib').Path({str(marker)!r}).touch()"
    text = f'foo("{payload}")'
    with pytest.raises(ExpressionError, match="string literal"):
        parse_expression(text, SYMS)
    model = tmp_path / "evil.toml"
    model.write_text(
        'name = "evil"\n[parameters]\nm1 = { value = 1.0 }\n[[joints]]\ndh = { a = 1 }\n'
        f"mass = {_toml_string(text)}\n",
        encoding="utf-8",
    )
    with pytest.raises(ModelFileError, match=r"line 6 .*string literal \(quotes\) is not allowed"):
        load_model(model, cache=False)
    assert not marker.exists()


def test_a_quoted_string_expression_runs_nothing(tmp_path):
    """Exploit 2 of the issue: an expression that is itself a string went through sympify."""
    marker = tmp_path / "pwned"
    text = repr(f"__import__('pathlib').Path({str(marker)!r}).touch() or 1")
    model = tmp_path / "evil.toml"
    model.write_text(
        'name = "evil"\n[parameters]\nm1 = { value = 1.0 }\n[[joints]]\ndh = { a = 1 }\n'
        f"mass = {_toml_string(text)}\n",
        encoding="utf-8",
    )
    with pytest.raises(ModelFileError, match="string literal"):
        load_model(model, cache=False)
    with pytest.raises(ExpressionError):
        evaluate_expression(text, {})
    assert not marker.exists()


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


# ------------------------------------------------------------------ values at the nominal point
def test_check_real_at():
    m = sp.Symbol("m")
    assert check_real_at(parse_expression("sqrt(m)", {"m": m}), {m: 4.0}) == 2.0
    with pytest.raises(ExpressionError, match=r"at m=2 is not a finite real number"):
        check_real_at(parse_expression("sqrt(-m)", {"m": m}), {m: 2.0}, text="sqrt(-m)")
    with pytest.raises(ExpressionError, match="not a finite real number"):
        check_real_at(parse_expression("1/(m - 2)", {"m": m}), {m: 2.0})


HEAD = 'name = "arm"\n[parameters]\nm1 = { value = 2.0, unit = "kg" }\nl1 = { value = 0.5 }\n'


@pytest.mark.parametrize(
    ("joint", "pattern"),
    [
        ('dh = { a = "l1" }\nmass = "sqrt(-m1)"\n', r"line 7 \(joints\[1\]\.mass\): .*sqrt\(-m1\)"),
        ('dh = { a = "1/(l1 - 0.5)" }\nmass = "m1"\n', r"line 6 .*dh\.a: .*no finite real value"),
        ('dh = { a = "l1" }\nmass = "m1"\nviscous = "log(l1 - l1)"\n', r"viscous.*finite real"),
        (
            'dh = { a = "l1" }\nmass = "m1/0"\n',
            r"line 7 .*'m1/0' has no finite real value .*got inf",
        ),
        ('dh = { a = "l1" }\nmass = "m1**1e9"\n', r"line 7 .*exponent .* exceeds the limit"),
        ('dh = { a = "l1" }\nmass = "m1 //2"\n', r"line 7 .*floor division"),
    ],
)
def test_model_expressions_without_a_real_value_name_their_line(tmp_path, joint, pattern):
    path = tmp_path / "arm.toml"
    path.write_text(HEAD + "[[joints]]\n" + joint, encoding="utf-8")
    with pytest.raises(ModelFileError, match=pattern):
        load_model(path, cache=False)


def test_nominal_values_are_checked_on_a_warm_cache_too(tmp_path, monkeypatch):
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path / "cache"))
    good = tmp_path / "good.toml"
    good.write_text(HEAD + '[[joints]]\ndh = { a = "l1" }\nmass = "m1/(l1 - 0.4)"\n', "utf-8")
    load_model(good)  # derives and caches
    bad = tmp_path / "bad.toml"
    bad.write_text(HEAD.replace("0.5", "0.4") + good.read_text("utf-8")[len(HEAD) :], "utf-8")
    with pytest.raises(ModelFileError, match="no finite real value"):
        load_model(bad)


# ------------------------------------------------------------------ numeric evaluation
def test_evaluate_expression_numbers_and_arrays():
    vir = np.array([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(
        evaluate_expression("gtau*vir", {"gtau": 2.0, "vir": vir}), 2 * vir
    )
    np.testing.assert_allclose(
        evaluate_expression("35.15*vir - 0.2 + sin(pi/2)", {"vir": vir}), 35.15 * vir + 0.8
    )
    assert evaluate_expression("2^3", {}).shape == ()
    assert float(evaluate_expression("2^3", {})) == 8.0


def test_evaluate_expression_dotted_struct_fields():
    out = evaluate_expression("data.pos*2", {"data.pos": np.array([1.0, 2.0])})
    np.testing.assert_array_equal(out, [2.0, 4.0])
    with pytest.raises(ExpressionError, match=r"unknown name\(s\) \['data\.vel'\]"):
        evaluate_expression("data.vel", {"data.pos": 1.0})
    with pytest.raises(ExpressionError, match=r"unknown name\(s\) \['mydata\.pos'\]"):
        evaluate_expression("mydata.pos", {"data.pos": 1.0})


def test_evaluate_expression_is_quiet_on_invalid_values(recwarn):
    out = evaluate_expression("log(x) + 1/y", {"x": np.array([-1.0]), "y": np.array([0.0])})
    assert np.isnan(out[0])
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("__import__('os')", "string literal"),
        ("x.__class__", r"unknown name\(s\) \['x\.__class__'\]"),
        ("x[0]", "subscript"),
        ("9**9**9", "exceeds the limit"),
        ("y", r"unknown name\(s\) \['y'\]"),
    ],
)
def test_evaluate_expression_refuses_like_the_parser(text, pattern):
    with pytest.raises(ExpressionError, match=pattern):
        evaluate_expression(text, {"x": np.ones(3)})
