import numpy as np
import pytest

from physid import InputError, Recording, SamplingError, ShapeError


def test_recording_copies_and_freezes_inputs():
    t = np.linspace(0, 1, 11)
    data = np.column_stack([t, 2 * t])
    rec = Recording(t, data, ["a", "b"], units=["m", "s"])
    data[0, 0] = 99.0
    assert rec["a"][0] == 0.0
    with pytest.raises(ValueError):
        rec.data[0, 0] = 1.0
    assert rec.dt == pytest.approx(0.1)
    assert rec.unit("b") == "s"
    np.testing.assert_array_equal(rec.select(["b", "a"]), np.column_stack([2 * t, t]))


def test_recording_from_columns_expands_2d():
    t = np.arange(5) * 0.01
    rec = Recording.from_columns(t, {"q": np.ones((5, 2)), "u": t}, units={"q": "rad"})
    assert rec.names == ("q1", "q2", "u")
    assert rec.units == ("rad", "rad", "")
    assert rec.channels("q") == ["q1", "q2"]


@pytest.mark.parametrize(
    ("t", "data", "names", "match"),
    [
        ([0, 1, 1], [1, 2, 3], ["x"], "strictly increasing"),
        ([0, 1, 2], [1, 2], ["x"], "rows but t has"),
        ([0, 1, 2], [[1, 1], [2, 2], [3, 3]], ["x", "x"], "duplicate channel"),
        ([0, 1, 2], [1, np.nan, 3], ["x"], r"channel 'x', row 1"),
        ([0, 1, 2], [1, 2, 3], ["x", "y"], "one name per column"),
    ],
)
def test_recording_rejects_bad_input(t, data, names, match):
    with pytest.raises((InputError, SamplingError, ShapeError), match=match):
        Recording(t, data, names)


def test_non_uniform_sampling_reports_worst_deviation_and_resample_fixes_it():
    t = np.array([0.0, 0.1, 0.2, 0.35, 0.4])
    rec = Recording(t, t**2, ["x"])
    with pytest.raises(SamplingError, match=r"not uniformly sampled.*after sample 3"):
        _ = rec.dt
    uni = rec.resample(0.1)
    assert uni.dt == pytest.approx(0.1)
    np.testing.assert_allclose(uni["x"], np.interp(uni.t, t, t**2))


def test_missing_channel_names_what_exists():
    rec = Recording([0, 1], [1, 2], ["x"])
    with pytest.raises(InputError, match=r"no channel 'y'.*\['x'\]"):
        rec["y"]


@pytest.mark.parametrize("bad", [0.0, -0.1, float("nan"), float("inf"), "0.1", True])
def test_resample_rejects_bad_period(bad):
    rec = Recording([0.0, 0.1, 0.3], [0.0, 1.0, 3.0], ["x"])
    with pytest.raises(InputError, match=r"dt must be a finite number > 0 \[s\] or None"):
        rec.resample(bad)


def test_resample_needs_two_samples():
    with pytest.raises(SamplingError, match=r"at least 2 samples; the recording has 1"):
        Recording([0.0], [1.0], ["x"]).resample()


def test_with_channels_and_slice_time():
    t = np.arange(5) * 0.5
    rec = Recording(t, t, ["x"], units=["m"])
    out = rec.with_channels({"x": 2 * t, "v": np.ones(5)}, units={"v": "m/s"})
    assert out.names == ("x", "v") and out.units == ("m", "m/s")  # replaced x keeps its unit
    np.testing.assert_array_equal(out["x"], 2 * t)
    np.testing.assert_array_equal(rec["x"], t)  # the original is unchanged
    with pytest.raises(ShapeError, match=r"column 'v' has 4 samples; the recording has 5"):
        rec.with_channels({"v": np.ones(4)})
    np.testing.assert_array_equal(rec.slice_time(0.5, 1.5).t, [0.5, 1.0, 1.5])
    with pytest.raises(SamplingError, match=r"no sample lies in \[3\.0, 4\.0\] s"):
        rec.slice_time(3.0, 4.0)
