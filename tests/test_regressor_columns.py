"""The compiled regressor written column by column into a caller's rows (no full Y in memory)."""

import numpy as np
import pytest

import physid
from physid.estimators.idim import base_regressor_info
from physid.estimators.idim.base_parameters import base_regressor, write_in_place


class _Plain:
    """The model seen through `regressor` alone (the gather done in numpy)."""

    def __init__(self, model):
        self._model = model

    def regressor(self, q, qd, qdd):
        return self._model.regressor(q, qd, qdd)


@pytest.mark.parametrize("name", ["arm6", "tests/data/arm7.urdf", "tests/data/arm3_prismatic.urdf"])
def test_columns_written_in_place_equal_the_full_regressor_gathered(name):
    model = physid.load_model(name)
    info = base_regressor_info(model)
    nj, p = model.n_joints, info.n_base
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.normal(size=(3, 1000, nj))
    want = base_regressor(_Plain(model), info.columns, q, qd, qdd, block=300)
    np.testing.assert_array_equal(base_regressor(model, info.columns, q, qd, qdd, block=300), want)
    # into the leading columns of wider rows ([W | τ]), the other columns untouched
    rows = np.full((1000, nj * p + nj), 7.0)
    write_in_place(
        rows[:, : nj * p],
        nj,
        p,
        lambda out: base_regressor(model, info.columns, q, qd, qdd, block=300, out=out),
    )
    np.testing.assert_array_equal(rows[:, : nj * p].reshape(1000, nj, p), want)
    assert np.all(rows[:, nj * p :] == 7.0)


def test_a_destination_that_does_not_fit_is_refused():
    model = physid.load_model("arm6")
    kernel = model._core_kernel()
    if kernel is None:  # no C compiler: the numpy path has no such check to test
        assert base_regressor(model, [0, 1], *np.zeros((3, 5, 6))).shape == (5, 6, 2)
        return
    q = np.zeros((5, 6))
    with pytest.raises(ValueError, match="do not fit"):
        kernel.regressor_columns(q, q, q, [0, 1], np.empty((5, 6, 3)))
    with pytest.raises(ValueError, match="do not fit"):
        kernel.regressor_columns(q, q, q, [0, 10_000], np.empty((5, 6, 2)))
