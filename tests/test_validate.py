"""physid._validate: the shared argument checks."""

from __future__ import annotations

import numpy as np
import pytest

from physid._validate import check_int, parameter_vector, per_joint, sample_period
from physid.errors import InputError, SamplingError, ShapeError


def test_sample_period_is_the_least_squares_slope():
    """A grid built by accumulation drifts; the period is the slope of t against the index."""
    t = np.cumsum(np.full(10_000, 1e-3))
    slope = np.polyfit(np.arange(t.size), t, 1)[0]
    assert sample_period(t) == pytest.approx(slope, rel=1e-12)
    assert sample_period(t) != (t[-1] - t[0]) / (t.size - 1)  # not the end points
    # an exactly uniform grid gets exactly its step back
    assert sample_period(np.arange(5001) * 1e-3) == 1e-3
    assert sample_period([0.0, 0.5, 1.0, 1.5]) == 0.5


def test_sample_period_refuses_non_uniform_and_short_vectors():
    with pytest.raises(SamplingError, match="not uniformly sampled: the interval after sample 3"):
        sample_period([0.0, 0.1, 0.2, 0.35, 0.4])
    with pytest.raises(SamplingError, match="at least 2 samples"):
        sample_period([1.0])


@pytest.mark.parametrize(
    ("value", "kwargs", "match"),
    [
        (True, {}, r"trials must be an integer; got True of type bool"),
        (2.0, {}, r"got 2\.0 of type float\. Pass 2 \(an int, not a float\)"),
        ("3", {}, r"got '3' of type str"),
        (0, {"minimum": 1}, r"trials must be an integer >= 1; got 0"),
        (9, {"minimum": 1, "maximum": 5}, r"an integer in \[1, 5\]; got 9"),
        (None, {}, r"got None of type NoneType"),
    ],
)
def test_check_int_refuses(value, kwargs, match):
    with pytest.raises(InputError, match=match):
        check_int(value, "trials", **kwargs)


def test_check_int_accepts():
    assert check_int(np.int64(7), "n", minimum=1) == 7 and type(check_int(np.int64(7), "n")) is int
    assert check_int(None, "n", allow_none=True) is None


def test_per_joint_forms_and_errors():
    assert per_joint(3.0, "kp", 2).tolist() == [3.0, 3.0]
    assert per_joint([1, 2, 3], "kp", 3).tolist() == [1.0, 2.0, 3.0]
    assert per_joint({"2": 5.0, "kp1": 4.0}, "kp", 2).tolist() == [4.0, 5.0]
    with pytest.raises(ShapeError, match=r"kp must hold one value per joint \(3\)"):
        per_joint([1, 2], "kp", 3)
    with pytest.raises(InputError, match=r"missing \['kp2'\], unknown \['kq1'\]"):
        per_joint({"kp1": 1.0, "kq1": 2.0}, "kp", 2)
    with pytest.raises(InputError, match="non-finite"):
        per_joint([1.0, np.inf], "kp", 2)


def test_parameter_vector_overrides_and_errors():
    names, nominal = ["c", "k"], [1.0, 2.0]
    assert parameter_vector({"k": 4.0}, names, nominal).tolist() == [1.0, 4.0]
    assert parameter_vector([5.0, 6.0], names, nominal).tolist() == [5.0, 6.0]
    out = parameter_vector(None, names, nominal)
    out[0] = 99.0  # a new array: the nominal values are untouched
    assert nominal == [1.0, 2.0]
    with pytest.raises(InputError, match=r"params\['k'\] must be a number; got 'x'"):
        parameter_vector({"k": "x"}, names, nominal)
