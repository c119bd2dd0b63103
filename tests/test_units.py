"""The unit table of `physid.units`: scales to SI, dimensions, refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from physid.errors import InputError
from physid.units import (
    dimension_name,
    expected_dimensions,
    parse_unit,
    same_dimension,
    to_si,
)


@pytest.mark.parametrize(
    ("text", "scale", "si"),
    [
        ("", 1.0, ""),
        ("m", 1.0, "m"),
        ("mm", 1e-3, "m"),
        ("cm", 1e-2, "m"),
        ("um", 1e-6, "m"),
        ("µm", 1e-6, "m"),
        ("in", 0.0254, "m"),
        ("deg", math.pi / 180, "rad"),
        ("°", math.pi / 180, "rad"),
        ("rev", 2 * math.pi, "rad"),
        ("ms", 1e-3, "s"),
        ("us", 1e-6, "s"),
        ("min", 60.0, "s"),
        ("h", 3600.0, "s"),
        ("kN", 1e3, "N"),
        ("mN", 1e-3, "N"),
        ("lbf", 4.4482216152605, "N"),
        ("Nm", 1.0, "Nm"),  # already SI: the spelling is kept
        ("N·m", 1.0, "N·m"),
        ("N*m", 1.0, "N*m"),
        ("mNm", 1e-3, "N·m"),
        ("kNm", 1e3, "N·m"),
        ("Nmm", 1e-3, "N·m"),
        ("rpm", 2 * math.pi / 60, "rad/s"),
        ("deg/s", math.pi / 180, "rad/s"),
        ("deg/s^2", math.pi / 180, "rad/s^2"),
        ("rad/s²", 1.0, "rad/s²"),
        ("mm/s", 1e-3, "m/s"),
        ("mm/s**2", 1e-3, "m/s^2"),
        ("mm/s2", 1e-3, "m/s^2"),
        ("g", 1e-3, "kg"),
        ("kg", 1.0, "kg"),
        ("mV", 1e-3, "V"),
        ("kHz", 1e3, "1/s"),
        ("N·s/m", 1.0, "N·s/m"),
        ("kg/(m·s)", 1.0, "kg/(m·s)"),
        ("%", 0.01, ""),
    ],
)
def test_scales_and_si_units(text, scale, si):
    u = parse_unit(text)
    assert u.scale == pytest.approx(scale, rel=1e-15)
    assert u.si == si


def test_dimensions_tell_kinds_apart():
    assert parse_unit("N*m").dimension == parse_unit("mNm").dimension == (2, 1, -2, 0, 0)
    assert parse_unit("nm").dimension == (1, 0, 0, 0, 0)  # nanometre, not newton-metre
    assert not same_dimension("deg", "m")  # an angle is never read as a length
    assert same_dimension("rpm", "rad/s") and same_dimension("kN", "lbf")
    assert dimension_name(parse_unit("V").dimension) == "a voltage"
    assert dimension_name(parse_unit("N·m").dimension) == "a torque"
    assert dimension_name(parse_unit("kg·m^2").dimension).startswith("a quantity in kg·m^2")


def test_to_si_is_exact_for_si_units_and_scales_others():
    x = np.array([0.1, 1e-17, -3.0])
    same, unit = to_si(x, "m")
    assert unit == "m" and np.array_equal(same, x)
    deg, unit = to_si([180.0], "deg")
    assert unit == "rad" and deg[0] == pytest.approx(math.pi, rel=1e-15)


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("counts", r"unknown unit 'counts' \(the factor 'counts' is not in physid's table\)"),
        ("degC", r"unknown unit 'degC'"),
        ("m/s/s", r"more than one '/'"),
        ("m^9", r"the power 9 is outside -4\.\.4"),
        ("m^^2", r"malformed"),
        ("x" * 70, r"too long"),
        ("cN", r"unknown unit 'cN'"),  # centi only for metres
    ],
)
def test_refusals_name_the_unit_and_the_table(text, pattern):
    with pytest.raises(InputError, match=pattern):
        parse_unit(text)


def test_non_string_unit_is_refused():
    with pytest.raises(InputError, match=r"a unit must be a string; got 3 of type int"):
        parse_unit(3)


def test_expected_dimensions_of_the_naming_convention():
    assert [u for _, u in expected_dimensions("q3")] == ["rad", "m"]
    assert [u for _, u in expected_dimensions("qd1")] == ["rad/s", "m/s"]
    assert [u for _, u in expected_dimensions("tau12")] == ["N·m", "N"]
    assert [u for _, u in expected_dimensions("t")] == ["s"]
    assert expected_dimensions("x") is None and expected_dimensions("tau") is None
