"""The parallel filter's end rows: exact equations for every edge (the filter is linear).

``parallel_decimate`` applies one linear map L (forward-backward Chebyshev with odd-extension
padding of ``padlen = edge`` samples) to every column of ``[W | τ]``. If ``τ = W β`` sample by
sample then ``L τ = (L W) β`` at every output row, the first and last included, whatever the
padding: the rows next to the ends are exact equations; only their noise differs.
"""

import numpy as np
import pytest
from scipy import signal

from physid.estimators.idim import decimation
from physid.estimators.idim.decimation import (
    _decimation_sos,
    decimation_edge,
    parallel_decimate,
)
from physid.filters.lifted import lifting_pays


def _equations(n, p, seed):
    """Columns W (white noise plus a ramp and an offset: large end values), β, τ = W β."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    W = rng.normal(size=(n, p))
    W[:, 0] += 50.0 + 30.0 * t
    W[:, 1] += 20.0 * np.sin(7.0 * t) ** 3
    beta = rng.normal(size=p)
    return W, beta, W @ beta


@pytest.mark.parametrize("periods", [0, 3, 12])
@pytest.mark.parametrize(("nd", "p"), [(5, 6), (11, 6), (40, 10)])  # 40: the lifted kernel
def test_filtered_equations_hold_exactly_at_every_row(monkeypatch, periods, nd, p):
    monkeypatch.setattr(decimation, "EDGE_PERIODS", periods)
    n = 4000
    W, beta, tau = _equations(n, p, seed=nd + periods)
    dec, kept = parallel_decimate(np.c_[W, tau], nd)
    edge = decimation_edge(nd)
    assert edge == periods * nd
    assert np.array_equal(kept, np.arange(edge, n - edge, nd))
    assert lifting_pays(nd, n - edge, p + 1) == (nd == 40)
    # the same rows as scipy's forward-backward filter with the padding as used (padlen = edge)
    ref = signal.sosfiltfilt(_decimation_sos(nd), np.c_[W, tau], axis=0, padlen=edge)[kept]
    assert np.max(np.abs(dec - ref)) <= 1e-12 * np.max(np.abs(ref))
    # every row, the end rows included, is an exact equation
    resid = dec[:, :p] @ beta - dec[:, p]
    scale = np.abs(dec[:, :p]) @ np.abs(beta)
    assert np.max(np.abs(resid) / scale) <= 1e-12
