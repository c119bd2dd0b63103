"""The estimator registry and the one result schema."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import signal

import physid
from physid import Recording
from physid.errors import InputError, PhysidError, ShapeError
from physid.estimators import (
    AlgebraicEstimator,
    AlgebraicSettings,
    ParameterDict,
    RecursiveLeastSquares,
    make,
    methods,
    register,
)
from physid.estimators.results import SCHEMA_KEYS, save_result

T = np.arange(3000) * 1e-3
U = np.sin(10 * T) + 0.5 * np.sin(23 * T)
X = signal.lsim(([1.0], [1.0, 2.0, 100.0]), U, T)[1]
REC = Recording(T, np.c_[U, X], ["u", "x"])


@pytest.fixture(scope="module", params=["algebraic", "rls"])
def fitted(request):
    return request.param, make(request.param, "msd").fit(REC).result_


def test_registry_builds_every_linear_method():
    assert {"algebraic", "rls", "input-error"} <= set(methods())
    assert set(methods("linear_ode")) >= {"algebraic", "rls"}
    assert isinstance(make("algebraic", "msd", window=0.1), AlgebraicEstimator)
    assert make("rls", "msd", forgetting=0.99).forgetting == 0.99
    with pytest.raises(InputError, match="method must be one of"):
        make("nope", "msd")
    with pytest.raises(InputError, match="does not take the setting"):
        make("rls", "msd", window=0.1)
    with pytest.raises(InputError, match="already registered"):
        register("rls", lambda model, **kw: None, kind="linear_ode")
    with pytest.raises(InputError, match="kind must be one of"):
        register("x-new", lambda model, **kw: None, kind="robot")


def test_every_result_has_the_schema(fitted):
    method, res = fitted
    d = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert set(SCHEMA_KEYS) <= set(d) and d["method"] == method
    assert d["names"] == ["theta1", "theta2"]
    assert set(d["parameters"]) == set(d["names"])  # fitted only
    assert d["derived"]["natural_frequency"] == pytest.approx(10.0, rel=1e-4)
    if method == "algebraic":
        # on this noise-free record the default lies 2-4 of its (rounding-level) standard
        # errors from the bias-compensated estimate, so it withholds them and says why
        assert d["stderr"] is None and "final='bias-compensated'" in d["stderr_reason"]
        d = make("algebraic", "msd", final="bias-compensated").fit(REC).result_.to_dict()
    assert set(d["stderr"]) == set(d["names"])
    assert d["units"]["natural_frequency"] == "rad/s" and d["units"]["theta1"] == "1/s"
    assert res.history.shape == (T.size, 2)
    assert d["success"] is True and d["fit_percent"] > 99.9
    assert "(derived)" in res.summary() and "[rad/s]" in res.summary()


def test_predict_reproduces_the_record(fitted):
    _, res = fitted
    pred = res.predict(REC)
    assert pred.names == ("u", "x")
    np.testing.assert_allclose(pred["x"], X, atol=1e-5 * np.abs(X).max())


def test_parameters_keep_the_old_derived_lookup_with_a_warning(fitted):
    _, res = fitted
    assert "natural_frequency" not in res.parameters
    with pytest.warns(DeprecationWarning, match="result.derived"):
        w = res.parameters["natural_frequency"]
    assert w == res.derived["natural_frequency"]
    with pytest.raises(KeyError):
        ParameterDict({"a": 1.0})["b"]


def test_to_pandas_table_or_clear_error(fitted):
    _, res = fitted
    try:
        import pandas  # noqa: F401
    except ImportError:
        with pytest.raises(PhysidError, match="pip install physid\\[pandas\\]"):
            res.to_pandas()
    else:
        df = res.to_pandas()
        assert list(df.index) == ["theta1", "theta2", "natural_frequency", "damping_ratio"]
        assert list(df["kind"]) == ["fitted", "fitted", "derived", "derived"]


def test_plot_into_given_axes(fitted):
    from matplotlib.figure import Figure

    _, res = fitted
    fig = Figure()
    ax = fig.subplots()
    assert res.plot(ax=ax) is fig


def test_get_set_params_and_repr():
    est = RecursiveLeastSquares("msd", forgetting=0.99)
    params = est.get_params()
    assert params["forgetting"] == 0.99 and params["model"] == "msd"
    assert est.set_params(forgetting=0.95) is est and est.forgetting == 0.95
    assert repr(est) == "RecursiveLeastSquares(forgetting=0.95)"
    with pytest.raises(InputError, match="no setting"):
        est.set_params(window=1.0)
    alg = AlgebraicEstimator("msd", window=0.1)
    assert repr(alg) == "AlgebraicEstimator(window=0.1)"
    assert alg.settings == AlgebraicSettings(window=0.1)


def test_fit_arrays_is_the_plain_array_path():
    a = RecursiveLeastSquares("msd").fit_arrays(T, u=U, x=X).result_
    b = RecursiveLeastSquares("msd").fit(REC).result_
    np.testing.assert_array_equal(a.estimates, b.estimates)
    with pytest.raises(InputError, match="channels by name"):
        RecursiveLeastSquares("msd").fit_arrays(T)


def test_result_file_round_trip(tmp_path, fitted):
    _, res = fitted
    path = save_result(res, tmp_path / "r.json", model="msd", recording=tmp_path / "data.csv")
    d = json.loads(open(path).read())
    assert d["format"] == "physid-result" and d["model"] == "msd"
    assert d["parameters"] == pytest.approx(dict(res.parameters))
    with pytest.raises(InputError, match="is the recording"):
        save_result(res, tmp_path / "d.csv", recording=tmp_path / "d.csv")


def test_fit_arrays_names_the_channel_of_a_wrong_shape():
    t = np.arange(1000) * 1e-3
    est = physid.estimators.make("rls", "msd")
    with pytest.raises(ShapeError, match=r"channel 'u' has 999 samples but t has 1000"):
        est.fit_arrays(t, u=np.ones(999), x=np.sin(t))
    with pytest.raises(ShapeError, match=r"u must be one-dimensional; got shape \(1000, 2\)"):
        est.fit_arrays(t, u=np.ones((1000, 2)), x=np.sin(t))
