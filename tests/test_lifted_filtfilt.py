"""The lifted forward-backward filter (`physid.filters.lifted`) against `scipy.signal.sosfiltfilt`,
whole-record and window by window."""

import numpy as np
import pytest
from scipy import signal

from physid.errors import InputError
from physid.estimators.idim.decimation import _decimation_sos, decimation_edge, parallel_decimate
from physid.estimators.idim.stream_filter import decimated_window
from physid.filters.lifted import (
    LIFT_MIN_ND,
    decimated_filtfilt,
    lifting_pays,
    sosfiltfilt_decimated,
)


def _rel(got, ref):
    """Largest normwise relative difference of a column (row of (k, m))."""
    return float(np.max(np.linalg.norm(got - ref, axis=-1) / np.linalg.norm(ref, axis=-1)))


def _signals(n, nd, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / (40.0 * nd)
    smooth = np.vstack([100 + 5 * np.sin(2 * np.pi * 0.3 * t), 1e3 * np.sin(t) ** 3, t * np.cos(t)])
    return np.vstack([rng.normal(size=(2, n)), smooth])


# the whole record's own rounding grows with nd (poles near 1): scipy float64 against an
# 80-bit literal sosfilt gave 1.0e-13 (nd 50), 1.9e-12 (327), 1.4e-11 (1000), the lifted
# filter 7.7e-14, 5.4e-12, 2.9e-11
TOL = {2: 1e-13, 5: 1e-13, 12: 1e-13, 50: 5e-13, 327: 3e-11, 1000: 2e-10}


@pytest.mark.parametrize("nd", sorted(TOL))
@pytest.mark.parametrize("blocks", [3, 40])
def test_lifted_equals_sosfiltfilt_at_the_kept_rows(nd, blocks):
    sos = _decimation_sos(nd)
    n = blocks * nd + 2 * decimation_edge(nd) + 7
    padlen = min(n - 1, decimation_edge(nd))
    x = _signals(n, nd, nd + blocks)
    ref = signal.sosfiltfilt(sos, x, axis=-1, padlen=padlen)
    for first in (0, 1, nd - 1, padlen, n - 1):
        got = sosfiltfilt_decimated(sos, x, nd, first, padlen=padlen, lift=True)
        assert got.shape == ref[:, first::nd].shape
        assert _rel(got, ref[:, first::nd]) < TOL[nd], (first, _rel(got, ref[:, first::nd]))
    # the rule's choice (sosfilt below LIFT_MIN_ND) gives the same rows
    auto = sosfiltfilt_decimated(sos, x, nd, padlen, padlen=padlen)
    assert _rel(auto, ref[:, padlen::nd]) < TOL[nd]


def test_short_record_single_column_and_no_column():
    nd = 20
    sos = _decimation_sos(nd)
    for n in (2, nd, nd + 1, 2 * nd, 2 * nd + 1):  # just long enough for 0, 1, 2 blocks
        x = np.cos(np.arange(n) / 7.0)[None, :]
        ref = signal.sosfiltfilt(sos, x, axis=-1, padlen=n - 1)[:, ::nd]
        got = sosfiltfilt_decimated(sos, x, nd, padlen=n - 1, lift=True)
        assert _rel(got, ref) < 1e-12
    none = sosfiltfilt_decimated(sos, np.empty((0, 500)), nd, padlen=240, lift=True)
    assert none.shape == (0, 25)
    assert sosfiltfilt_decimated(sos, np.ones((2, 500)), nd, 0, 0, padlen=240).shape == (2, 0)
    # scipy's default padlen
    x = np.random.default_rng(0).normal(size=(1, 4000))
    ref = signal.sosfiltfilt(sos, x)[:, 3::nd]
    assert _rel(sosfiltfilt_decimated(sos, x, nd, 3, lift=True), ref) < 1e-13


@pytest.mark.parametrize("lift", [True, False])
def test_rows_that_end_at_the_records_last_sample(lift):
    # no padding and the last block ending exactly at the record's end: the forward state
    # wanted is the record's final one
    sos = _decimation_sos(10)
    x = np.random.default_rng(5).normal(size=(3, 1000))
    got = sosfiltfilt_decimated(sos, x, 10, padlen=0, lift=lift)
    assert _rel(got, signal.sosfiltfilt(sos, x, padlen=0)[:, ::10]) < 1e-12
    y, state = decimated_filtfilt(sos, x.T, 10, 100, 90, axis=0, lift=lift)
    assert y.shape == (90, 3) and state is not None


def test_returned_state_continues_the_forward_pass():
    nd, n = 25, 3000
    sos = _decimation_sos(nd)
    x = np.random.default_rng(3).normal(size=(2, n))
    _, z = decimated_filtfilt(sos, x, nd, 10, 40, lift=True)
    zi = signal.sosfilt_zi(sos)[:, None, :] * x[:, :1]
    _, ref = signal.sosfilt(sos, x[:, : 10 + 40 * nd], axis=-1, zi=zi)
    assert np.max(np.abs(z - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert decimated_filtfilt(sos, x, nd, 110, 116, lift=True)[1] is None  # past the end


def test_parallel_decimate_lifted_equals_sosfiltfilt():
    nd = 40
    x = np.random.default_rng(5).normal(size=(5000, 4, 3))  # 11 live columns: lifted
    x[:, 1, 0] = 0.0
    y, kept = parallel_decimate(x, nd)
    assert lifting_pays(nd, 5000, 11) and not lifting_pays(LIFT_MIN_ND - 1, 5000, 11)
    assert not lifting_pays(nd, 5000, 1) and not lifting_pays(nd, nd, 6)
    edge = decimation_edge(nd)
    ref = signal.sosfiltfilt(_decimation_sos(nd), x, axis=0, padlen=edge)[kept]
    assert np.array_equal(kept, np.arange(edge, 5000 - edge, nd))
    assert np.all(y[:, 1, 0] == 0.0)
    assert np.max(np.abs(y - ref)) <= 1e-13 * np.max(np.abs(ref))


@pytest.mark.parametrize("nd", [5, 20, 300])  # 5: plain sosfilt passes (no lifting), carried
def test_windows_of_uneven_length_carry_the_state(nd):
    """`decimated_window` over windows of uneven length (some without a kept row), each with a
    right margin: the rows equal the whole record's."""
    from physid.estimators.idim.stream_plan import decay_length
    from physid.estimators.idim.stream_window import PARALLEL_DECAY

    sos, edge = _decimation_sos(nd), decimation_edge(nd)
    n = 60 * nd + 2 * edge + 13
    padlen = min(n - 1, edge)
    margin = max(decay_length(sos, PARALLEL_DECAY), edge + 1)
    x = _signals(n, nd, 7).T  # (n, k), time on axis 0
    kept = np.arange(edge, n - edge, nd)
    ref = signal.sosfiltfilt(sos, x, axis=0, padlen=padlen)[kept]
    rng = np.random.default_rng(nd)
    got, pos, z, a = [], 0, None, 0
    while a < n:
        b = min(n, a + int(rng.integers(nd // 2 + 1, 9 * nd)))  # some shorter than nd
        c1 = min(n, b + margin)
        c0 = max(0, a - edge - 1)
        s = kept[(kept >= a) & (kept < b)]
        nxt = edge + max(0, -(-(b - edge) // nd)) * nd
        stop = s[0] if s.size else max(nxt, pos)
        y, z = decimated_window(sos, x[c0:c1], c0, c1, pos, stop, s.size, nd, z, n, padlen)
        got.append(y.T)
        pos, a = stop + s.size * nd, b
    got = np.concatenate(got)
    assert got.shape == ref.shape
    assert _rel(got.T, ref.T) < 1e-11
    # without the carried state (from rest at every window) the rows are wrong
    y, _ = decimated_window(sos, x, 0, n, kept[10], kept[10], 5, nd, np.zeros((4, 5, 2)), n, padlen)
    assert _rel(y, ref[10:15].T) > 1e-3


def test_bad_input_is_refused_in_the_arguments_words():
    sos = _decimation_sos(20)
    with pytest.raises(InputError, match="padlen must be in"):
        sosfiltfilt_decimated(sos, np.ones((1, 10)), 20, padlen=10)
    with pytest.raises(InputError, match="must be 2-D"):
        sosfiltfilt_decimated(sos, np.ones(100), 20)
    with pytest.raises(InputError, match="nd must be a positive integer"):
        decimated_filtfilt(sos, np.ones((1, 100)), 0, 0, 1)
    with pytest.raises(InputError, match="lies past"):
        decimated_filtfilt(sos, np.ones((1, 100)), 20, 10, 5 + 1)
    with pytest.raises(InputError, match="sos must have shape"):
        decimated_filtfilt(sos[:, :5], np.ones((1, 100)), 20, 0, 1)


def _closed_loop_record(model, duration):
    from physid.simulate.closed_loop import simulate_closed_loop

    t = np.arange(0.0, duration, 1e-3)
    w0 = 2 * np.pi * np.array([0.2, 0.3, 0.5, 0.7])
    ramp = np.clip(t, 0.0, 1.0)[:, None] ** 3
    ref = ramp * (0.8 * np.sin(np.outer(t, w0)) + 0.3 * np.sin(np.outer(t, 2.3 * w0) + 1))
    kp, kd = (3800.0, 40000.0, 10000.0, 500.0), (159.5, 120.0, 50.0, 2.0)
    return simulate_closed_loop(model, kp=kp, kd=kd, reference=ref, t=t, noise_std=1e-4, rng=1)


@pytest.mark.parametrize(("nd", "block"), [(20, 1000), (7, 777), (50, 2000)])  # 50: in place
def test_streamed_fit_lifted_equals_in_memory(monkeypatch, nd, block):
    """Lifting forced everywhere (any nd, any number of columns): the streamed fit equals the
    in-memory fit, and both equal the fit with sosfiltfilt everywhere."""
    import warnings

    import physid
    import physid.filters.lifted as lifted
    from physid.estimators.idim import IDIMEstimator, fit_streamed

    model = physid.load_model("manipulator")
    rec = _closed_loop_record(model, 8.0)

    def fits():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mem = IDIMEstimator(model, decimate=nd).fit(rec).result_
            st = fit_streamed(model, rec, decimate=nd, block_samples=block, progress=False)
        return mem, st

    calls = []  # the block-rate recursions run: the lifted path is the one tested
    recursion = lifted._recursion
    monkeypatch.setattr(
        lifted, "_recursion", lambda *a, **kw: calls.append(1) or recursion(*a, **kw)
    )
    monkeypatch.setattr(lifted, "LIFT_MIN_WORK", 10**9)
    plain, _ = fits()
    assert not calls
    monkeypatch.setattr(lifted, "LIFT_MIN_ND", 2)
    monkeypatch.setattr(lifted, "LIFT_MIN_WORK", 1)
    mem, st = fits()
    assert len(calls) > 8  # the in-memory fit and several windows
    b0, b1, b2 = plain.beta_vector(), mem.beta_vector(), st.beta_vector()
    assert mem.n_rows == st.n_rows == plain.n_rows
    np.testing.assert_allclose(b1, b0, rtol=1e-10, atol=0)
    np.testing.assert_allclose(b2, b1, rtol=1e-10, atol=0)
    s1, s2 = np.array(list(mem.stderr.values())), np.array(list(st.stderr.values()))
    np.testing.assert_allclose(s2, s1, rtol=1e-8, atol=0)


@pytest.mark.parametrize("nd", [20, 300])
def test_lifted_blocks_carried_to_the_next_window_give_the_same_rows_bit_for_bit(nd):
    """The blocks a window lifted past its last row (its right margin), carried to the next
    window that starts there: the rows and states bit for bit those computed afresh."""
    from physid.estimators.idim.stream_plan import decay_length
    from physid.estimators.idim.stream_window import PARALLEL_DECAY

    sos, edge = _decimation_sos(nd), decimation_edge(nd)
    n = 80 * nd + 2 * edge + 13
    padlen = min(n - 1, edge)
    margin = max(decay_length(sos, PARALLEL_DECAY), edge + 1)
    x = _signals(n, nd, 7).T
    kept = np.arange(edge, n - edge, nd)
    runs = {True: [], False: []}
    reused = 0
    for carried in (True, False):
        pos, z, a, carry = 0, None, 0, {}
        while a < n:
            b = min(n, a + 7 * nd + 3)
            c1 = min(n, b + margin)
            c0 = max(0, a - edge - 1)
            s = kept[(kept >= a) & (kept < b)]
            nxt = edge + max(0, -(-(b - edge) // nd)) * nd
            stop = s[0] if s.size else max(nxt, pos)
            if carry.get("next") != stop or pos != stop:
                carry.clear()
            reused += carried and "Z" in carry
            y, z = decimated_window(
                sos, x[c0:c1], c0, c1, pos, stop, s.size, nd, z, n, padlen, True,
                carry if carried else None,
            )  # fmt: skip
            carry["next"] = stop + s.size * nd
            runs[carried].append((y, z))
            pos, a = stop + s.size * nd, b
    assert reused > 5
    for (y1, z1), (y0, z0) in zip(runs[True], runs[False], strict=True):
        assert np.array_equal(y1, y0)
        assert (z1 is None and z0 is None) or np.array_equal(z1, z0)
    ref = signal.sosfiltfilt(sos, x, axis=0, padlen=padlen)[kept]
    got = np.concatenate([y.T for y, _ in runs[True]])
    assert _rel(got.T, ref.T) < 1e-11


def test_a_carry_made_with_another_nd_or_signals_is_refused():
    """A carry of lifted blocks made with another nd, sos or number of signals would give wrong
    rows silently (or broadcast one signal's blocks to all): refused, naming the argument."""
    nd = 50
    sos = _decimation_sos(nd)
    x = _signals(40 * nd + 7, nd, 3).T  # (n, 5), time on axis 0
    carry: dict = {}
    y, _ = decimated_filtfilt(sos, x, nd, 0, 10, axis=0, lift=True, carry=carry)
    assert carry["key"][0] == nd and carry["key"][2] == 5 and carry["Z"].shape[2] == 5
    # the same call again from the carried blocks: the same rows bit for bit
    again = {k: v for k, v in carry.items()}
    y2, _ = decimated_filtfilt(sos, x[10 * nd :], nd, 0, 10, axis=0, lift=True, carry=again)
    y3, _ = decimated_filtfilt(
        sos, x[10 * nd :], nd, 0, 10, axis=0, lift=True,
        forward_state=decimated_filtfilt(sos, x, nd, 0, 10, axis=0, lift=True)[1],
    )  # fmt: skip
    assert np.array_equal(y2, y3)
    other = _decimation_sos(60)
    with pytest.raises(InputError, match=r"carry holds blocks of another filter.*nd=50"):
        decimated_filtfilt(other, x, 60, 0, 10, axis=0, lift=True, carry=dict(carry))
    with pytest.raises(InputError, match=r"carry holds blocks.*5 signals.*this call: nd=50, 1 "):
        decimated_filtfilt(sos, x[:, :1], nd, 0, 10, axis=0, lift=True, carry=dict(carry))
    with pytest.raises(InputError, match="another sos"):
        decimated_filtfilt(sos * 1.0001, x, nd, 0, 10, axis=0, lift=True, carry=dict(carry))
    with pytest.raises(InputError, match="carry must be a dict"):
        decimated_filtfilt(sos, x, nd, 0, 10, axis=0, lift=True, carry=[1])
