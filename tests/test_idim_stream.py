"""Streamed IDIM (`physid.estimators.idim.stream`) equals the in-memory fit.

Kinds of test (docs STYLE.md): equivalence of forms (the streamed fit, read in blocks that do
not divide the record and smaller than the filters' margins, gives the in-memory
`IDIMEstimator` result: the same cut-off, half-width, decimation and rows, the estimate to 1e-10
and the standard errors to 1e-8 relative, the same message), exact merging of moments (a
map-reduce over sources equals one pass over both), invariants (the accumulators' size does not
grow with the record; pickling round trips), and error paths.
"""

from __future__ import annotations

import pickle
import warnings
from pathlib import Path

import numpy as np
import pytest

import physid
from physid.errors import InputError, SamplingError
from physid.estimators.idim import IDIMEstimator, fit_streamed, stream_plan
from physid.estimators.idim.stream import fit_moments, idim_moments, plan_streamed
from physid.signals.blocks import block_starts
from physid.signals.noise import median_rows, third_difference_sigma
from physid.signals.recording import Recording
from physid.simulate.closed_loop import simulate_closed_loop

KP = (3800.0, 40000.0, 10000.0, 500.0)
KD = (159.5, 120.0, 50.0, 2.0)
W0 = 2 * np.pi * np.array([0.2, 0.3, 0.5, 0.7])
DATA = Path(__file__).parent / "data"


def _run(model, duration, phase=0.0, seed=1):
    t = np.arange(0.0, duration, 1e-3)
    ramp = np.clip(t, 0.0, 1.0)[:, None] ** 3
    ref = ramp * (0.8 * np.sin(np.outer(t, W0) + phase) + 0.3 * np.sin(np.outer(t, 2.3 * W0) + 1))
    return simulate_closed_loop(model, kp=KP, kd=KD, reference=ref, t=t, noise_std=1e-4, rng=seed)


class ArrayBlocks:
    """A minimal block source over arrays (the protocol of `physid.signals.blocks`)."""

    def __init__(self, rec):
        self._rec = rec
        self.n_samples = rec.n_samples
        self.dt = float((rec.t[-1] - rec.t[0]) / (rec.n_samples - 1))
        self.t0 = float(rec.t[0])
        self.names, self.units, self.metadata = tuple(rec.names), tuple(rec.units), {}
        self.reads = 0

    def blocks(self, size, channels=None):
        names = list(channels or self.names)
        data = self._rec.select(names)
        starts = block_starts(self.n_samples, size)
        self.reads += 1
        for a, b in zip(starts[:-1], starts[1:], strict=True):
            yield Recording(self._rec.t[a:b], data[a:b].copy(), names, ["rad"] * len(names))


@pytest.fixture(scope="module")
def arm():
    return physid.load_model("manipulator")


@pytest.fixture(scope="module")
def rec(arm):
    return _run(arm, 8.0)


@pytest.fixture(scope="module")
def rec2(arm):
    return _run(arm, 6.0, phase=0.7, seed=2)


def _fit(model, recs, **settings):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return IDIMEstimator(model, **settings).fit(recs).result_


def _same(ref, got, beta_rtol=1e-10, sd_rtol=1e-8):
    assert (got.cutoff, got.half_width, got.decimate, got.n_rows) == (
        ref.cutoff,
        ref.half_width,
        ref.decimate,
        ref.n_rows,
    )
    b1, b2 = ref.beta_vector(), got.beta_vector()
    np.testing.assert_allclose(b2, b1, rtol=beta_rtol, atol=0)
    s1 = np.array(list(ref.stderr.values()))
    s2 = np.array(list(got.stderr.values()))
    np.testing.assert_allclose(s2, s1, rtol=sd_rtol, atol=0)
    assert got.condition_number == pytest.approx(ref.condition_number, rel=1e-10)
    for key, value in ref.relative_error.items():
        assert got.relative_error[key] == pytest.approx(value, rel=1e-8)
    assert got.success == ref.success
    assert got.message == ref.message
    assert got.reversal_joints == ref.reversal_joints


@pytest.mark.parametrize(
    ("settings", "block"),
    [
        ({}, 65536),
        ({}, 1000),  # smaller than the parallel filter's margin (~123·nd samples)
        ({"method": "wls"}, 777),
        ({"differentiation": "butterworth"}, 3001),
        ({"cutoff": 0.3, "decimate": 5}, 2000),
        ({"decimate": 1, "stderr": "iid"}, 2500),
        ({"method": "wls", "stderr": "iid", "per_joint_variance": False}, 1999),
    ],
)
def test_streamed_equals_in_memory(arm, rec, settings, block):
    ref = _fit(arm, rec, **settings)
    got = fit_streamed(arm, ArrayBlocks(rec), block_samples=block, progress=False, **settings)
    _same(ref, got)
    assert got.hac_lag == ref.hac_lag
    assert got.joint_sigma == pytest.approx(ref.joint_sigma, rel=1e-8)


@pytest.mark.parametrize("threshold", ["auto", 0.05, 0])
def test_coulomb_joint_stiction_rules_equal_in_memory(threshold):
    model = physid.load_model(DATA / "pendulum1.toml")
    t = np.arange(0.0, 10.0, 1e-3)
    r = 0.8 * np.sin(2 * np.pi * 0.5 * t) + 0.3 * np.sin(2 * np.pi * 1.3 * t + 0.4)
    rec = simulate_closed_loop(
        model,
        kp=[200.0],
        kd=[2 * np.sqrt(40.0)],
        reference=(r - r[0])[:, None],
        t=t,
        noise_std=1e-5,
        rng=3,
    )
    ref = _fit(model, rec, stick_threshold=threshold)
    got = fit_streamed(model, rec, stick_threshold=threshold, block_samples=900, progress=False)
    _same(ref, got)
    if threshold != 0:  # the record rests: equations were dropped, and the same ones
        assert "joint equations dropped" in got.message
    if threshold == "auto":
        assert got.reversal_joints == (1,)  # the reversal rows dropped after the first solve


def test_two_recordings_equal_in_memory(arm, rec, rec2):
    ref = _fit(arm, [rec, rec2])
    got = fit_streamed(arm, [rec, ArrayBlocks(rec2)], block_samples=1500, progress=False)
    _same(ref, got)
    assert got.n_recordings == 2


def test_moments_of_two_sources_sum_to_the_fit_over_both(arm, rec, rec2):
    plan = plan_streamed(arm, [rec, rec2], block_samples=2048)
    m0 = idim_moments(arm, plan, rec, 0)
    m1 = idim_moments(arm, plan, rec2, 1)
    merged = fit_moments(arm, plan, sum([m1, m0]))
    whole = fit_streamed(arm, [rec, rec2], block_samples=2048, progress=False)
    np.testing.assert_allclose(merged.beta_vector(), whole.beta_vector(), rtol=1e-12)
    assert merged.message == whole.message
    with pytest.raises(InputError, match="counted twice"):
        _ = m0 + m0
    with pytest.raises(SamplingError, match="lack source"):
        fit_moments(arm, plan, m0)


def test_plan_and_moments_pickle(arm, rec):
    plan = plan_streamed(arm, rec, block_samples=3000)
    moments = idim_moments(arm, plan, rec, 0)
    plan2 = pickle.loads(pickle.dumps(plan))
    moments2 = pickle.loads(pickle.dumps(moments))
    a, b = fit_moments(arm, plan, moments), fit_moments(arm, plan2, moments2)
    np.testing.assert_array_equal(a.beta_vector(), b.beta_vector())
    assert plan2.candidates == plan.candidates and plan2.cutoff == plan.cutoff


def _largest_arrays(moments):
    out = {}
    for nd, c in moments.candidates.items():
        arrays = [c.R, c.kept, c.lagged, c.tau_min]
        out[nd] = max(a.size for a in arrays if a is not None)
    return out


def test_memory_does_not_grow_with_the_record(arm, monkeypatch):
    monkeypatch.setattr(stream_plan, "MAX_KEPT_ROWS", 60)
    short, long = _run(arm, 6.0), _run(arm, 12.0)
    sizes, rows = [], []
    for r in (short, long):
        plan = plan_streamed(arm, r, cutoff=0.2, decimate=10, block_samples=1024)
        m = idim_moments(arm, plan, r, 0)
        sizes.append(_largest_arrays(m))
        rows.append(sum(w.shape[0] for w in m.candidates[10].sample["W"]))
    assert sizes[0] == sizes[1]
    assert max(rows) <= 60 and rows[1] >= 30
    res = fit_streamed(arm, long, cutoff=0.2, decimate=10, block_samples=1024, progress=False)
    assert res.n_rows > 1000 and res.t.size <= 60
    assert any("every" in w and "of the" in w for w in res.warnings)


def test_timings_are_filled(arm, rec):
    times = {}
    fit_streamed(arm, rec, progress=False, timings=times, block_samples=4000)
    for key in ("read", "state filter", "regressor", "parallel filter", "accumulate", "solve"):
        assert times[key] >= 0.0
    assert times["regressor"] > 0.0


def test_refusals_name_the_alternatives(arm, rec):
    with pytest.raises(InputError, match="method='ols' or method='wls'.*in memory") as err:
        fit_streamed(arm, rec, method="iv", progress=False)
    assert "--method idim-ols or --method idim-wls" in err.value.render({"method": "--method"})
    with pytest.raises(InputError, match="stderr='filtered'.*stderr='iid'"):
        fit_streamed(arm, rec, stderr="hac", progress=False)


def test_mismatched_sources_are_refused_by_name(arm, rec):
    slow = Recording(rec.t * 2.0, rec.data, rec.names, rec.units)
    with pytest.raises(SamplingError, match="source 2 .* sample period"):
        fit_streamed(arm, [rec, slow], progress=False)
    keep = [n for n in rec.names if n != "tau4"]
    fewer = Recording(rec.t, rec.select(keep), keep, [rec.unit(n) for n in keep])
    with pytest.raises(InputError, match=r"source 2 .*lacks channel\(s\) \['tau4'\]"):
        fit_streamed(arm, [rec, fewer], progress=False)


@pytest.mark.parametrize("n", [3001, 70001])
def test_welch_accumulated_in_blocks_gives_auto_cutoff(n):
    from physid.estimators.idim.filtering import auto_cutoff

    rng = np.random.default_rng(0)
    t = np.arange(n) * 1e-3
    q = np.c_[np.sin(2 * np.pi * 0.7 * t), 0.3 * np.cos(2 * np.pi * 1.9 * t)]
    q = q + 1e-4 * rng.normal(size=(n, 2))
    welch = stream_plan._Welch(n, q[:1000].mean(axis=0))
    for a in range(0, n, 7001):  # blocks that cut the Welch segments anywhere
        welch.add(q[a : a + 7001])
    assert welch.cutoff() == auto_cutoff(q)


def test_a_file_read_in_blocks_equals_the_in_memory_fit(arm, rec, tmp_path):
    from physid.signals.io import open_blocks, save_recording

    path = save_recording(rec, tmp_path / "run.npz")
    ref = _fit(arm, rec, method="wls")
    with open_blocks(path) as source:
        got = fit_streamed(arm, source, method="wls", block_samples=1234, progress=False)
    _same(ref, got)


def test_a_weakly_identified_record_fails_streamed_as_in_memory(tmp_path):
    from physid.cli import main

    data = tmp_path / "run.csv"  # arm6, 2 s, 1e-4 rad: condition number 1.7e4, torques fit 0.4 %
    assert main(["simulate", "arm6", "--out", str(data), "--quiet", "--noise-std", "1e-4",
                 "--seed", "1", "--duration", "2"]) == 0  # fmt: skip
    model, rec = physid.load_model("arm6"), physid.load_recording(data)
    memory = _fit(model, rec)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        streamed = fit_streamed(model, rec, progress=False, block_samples=900)
    assert memory.success is False and "Weakly identified" in memory.message
    assert streamed.success is False and "Weakly identified" in streamed.message


def _with_wrist_torque(rec, amplitude, cutoff_hz=None, noise=0.0, seed=5):
    """``rec`` with a torque on joint 4 that no model explains (a sinusoid of ``amplitude`` times
    its rms), optionally every torque low-passed at ``cutoff_hz`` (4th-order Butterworth,
    zero phase: filtered before logging) or with white noise of ``noise`` times its rms."""
    from scipy import signal

    names, t = list(rec.names), np.asarray(rec.t)
    x = np.asarray(rec.data, dtype=float).copy()
    cols = [names.index(f"tau{j + 1}") for j in range(4)]
    rms = np.sqrt(np.mean(x[:, cols] ** 2, axis=0))
    x[:, cols[3]] += amplitude * rms[3] * np.sin(2 * np.pi * 0.9 * t + 0.3)
    if cutoff_hz is not None:
        b, a = signal.butter(4, 2.0 * cutoff_hz * (t[1] - t[0]))
        x[:, cols] = signal.filtfilt(b, a, x[:, cols], axis=0)
    if noise:
        x[:, cols] += noise * rms * np.random.default_rng(seed).standard_normal((t.size, 4))
    return Recording(t, x, names, list(rec.units))


def test_a_torque_filtered_before_logging_is_judged_alike_streamed_and_in_memory(arm, rec):
    # the wrist's unexplained torque: relative error above 0.5 but below 5 % of the largest
    # joint's torque; the log's torques filtered at 10 Hz show no noise floor (their noise is
    # ~1e-7 of their rms), so the wrist is excused, streamed as in memory
    pre = _with_wrist_torque(rec, 2.0, cutoff_hz=10.0)
    ref = _fit(arm, pre)
    got = fit_streamed(arm, ArrayBlocks(pre), block_samples=1000, progress=False)
    _same(ref, got)
    assert ref.success and "tau4: relative error above 0.5" in ref.message
    assert "No floor" in ref.message
    # a noise-free record is judged the same way; with 1 % white noise on the torques the record
    # shows a floor, and the same wrist residual, far above it, fails the fit
    assert _fit(arm, _with_wrist_torque(rec, 2.0)).success
    noisy = _with_wrist_torque(rec, 2.0, noise=0.01)
    ref = _fit(arm, noisy)
    got = fit_streamed(arm, ArrayBlocks(noisy), block_samples=1000, progress=False)
    _same(ref, got)
    assert not ref.success and "on tau4" in ref.message and "torque-noise floor of" in ref.message


def test_parallel_filter_state_is_carried_through_windows_without_rows(arm, rec):
    # windows of 100 samples are shorter than the filters' edge: many hold no decimated row of
    # the largest nd, and the forward state must still pass through them
    ref = _fit(arm, rec, decimate=20)
    got = fit_streamed(arm, ArrayBlocks(rec), decimate=20, block_samples=100, progress=False)
    _same(ref, got)


def test_the_last_window_is_filtered_in_place_and_equals_in_memory(arm, rec, monkeypatch):
    # from IN_PLACE_ND on every window's parallel filter reads the rows in place (a view, no
    # copy of the live columns) and lifts, the last window's too (which ends at the record's
    # end, with no right margin); the carried test of non-zero columns gives the same rows
    import physid.estimators.idim.stream_window as sw

    calls = []
    inner = sw.decimated_window

    def spy(sos, rows, c0, c1, pos, first, count, nd, state, n_full, padlen, lift, carry):
        calls.append((c1 == n_full, lift, rows.flags.owndata, rows.shape[1]))
        return inner(sos, rows, c0, c1, pos, first, count, nd, state, n_full, padlen, lift, carry)

    monkeypatch.setattr(sw, "decimated_window", spy)
    nd = sw.IN_PLACE_ND + 10
    ref = _fit(arm, rec, decimate=nd)
    got = fit_streamed(arm, ArrayBlocks(rec), decimate=nd, block_samples=2000, progress=False)
    _same(ref, got)
    last = [c for c in calls if c[0]]
    assert len(calls) > 3 and last
    assert all(lift is True and not owns for _, lift, owns, _ in calls)
    # one call per window: the columns from the first live one to the last, read as one slice
    assert len({width for *_, width in calls[1:]}) == 1


@pytest.mark.parametrize("n", [1, 2, 3, 4, 1023, 1024, 65536, 65537])
def test_median_of_rows_equals_numpy_median_bit_for_bit(n):
    rng = np.random.default_rng(n)
    rows = np.stack(
        [
            rng.normal(size=n),
            np.round(rng.normal(size=n) * 3.0) * 0.25,  # a grid: ties at the middle
            rng.exponential(size=n) ** 4,  # skewed
            np.full(n, 7.0),
            np.where(np.arange(n) % max(1, n // 1024) == 0, 1e9, 0.0),  # a sample that lies
        ]
    )
    got = median_rows(rows)
    assert np.array_equal(got, np.median(rows, axis=1))
    rows[1, n // 2] = np.nan  # a NaN anywhere in a row: its median is NaN, as np.median's
    rows[3, 0] = np.nan
    got = median_rows(rows)
    assert np.array_equal(got, np.median(rows, axis=1), equal_nan=True)
    assert np.isnan(got[[1, 3]]).all() and np.isfinite(got[[0, 2, 4]]).all()


def test_noise_sigma_of_the_survey_and_the_in_memory_fit_is_numpys_mad_bit_for_bit():
    from physid.estimators._stiction import position_noise
    from physid.estimators.idim.verdict import torque_noise_sigma

    rng = np.random.default_rng(3)
    t = np.arange(30001) * 1e-3
    q = np.sin(np.outer(t, [1.0, 2.0, 3.0])) + 1e-4 * rng.normal(size=(t.size, 3))
    tau = np.cos(np.outer(t, [1.0, 0.5, 2.0])) + 0.02 * rng.normal(size=(t.size, 3))
    x = np.hstack([q, tau])
    d3 = np.diff(x, n=3, axis=0)  # the formula with numpy's medians
    expected = 1.4826 * np.median(np.abs(d3 - np.median(d3, axis=0)), axis=0) / np.sqrt(20.0)
    sigma = third_difference_sigma(x)
    assert np.array_equal(sigma, expected)
    assert np.array_equal(sigma[3:], torque_noise_sigma(tau))
    assert np.array_equal(sigma[:3], position_noise(q)[0])
    # white noise of std 0.02 alone: the estimate within 3 % (30 000 samples)
    assert third_difference_sigma(0.02 * rng.normal(size=(30000, 1)))[0] == pytest.approx(
        0.02, rel=0.03
    )


def test_window_buffers_hold_the_reused_rows_at_their_front_in_one_allocation():
    from physid.estimators.idim.stream_window import _reuse

    n, step, left, right = 2000, 100, 10, 40
    capacity = max(step + left + right, -(-3 * step // 2) + left)  # as window_rows'
    cache, made, reused = {}, set(), 0
    a = 0
    while a < n:
        b = n if n - a < step + step // 2 else a + step
        c0, c1 = max(0, a - left), min(n, b + right)
        stacked, qdf, start = _reuse(cache, c0, c1, 3, 1, capacity)
        assert stacked.shape == (c1 - c0, 3) and qdf.shape == (c1 - c0, 1)
        assert stacked.base is cache["buf"] and np.shares_memory(stacked, cache["buf"][:1])
        # the rows reused from the previous window are the ones it wrote
        assert np.array_equal(stacked[: start - c0, 0], np.arange(c0, start))
        assert np.array_equal(qdf[: start - c0, 0], -np.arange(c0, start))
        reused += start - c0
        stacked[start - c0 :] = np.arange(start, c1)[:, None]
        qdf[start - c0 :, 0] = -np.arange(start, c1)
        cache["rows"] = (c0, c1)
        made.add(id(cache["buf"]))
        a = b
    assert len(made) == 1 and cache["buf"].shape[0] == capacity  # the last window's included
    assert reused == 19 * (left + right)  # each of the 19 windows after the first: both margins
    with pytest.raises(RuntimeError, match="a window of 161 rows does not fit the buffers' 160"):
        _reuse(cache, 0, capacity + 1, 3, 1, capacity)


def _arm7_record(seconds: float, seed: int = 0) -> tuple:
    """A 7-DOF arm, 1 kHz: smooth 5-harmonic motion, torques from its inverse dynamics plus
    noise (2 % of each joint's rms), σ_q = 1e-4 rad."""
    model = physid.load_model(DATA / "arm7.urdf")
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * 1000)) * 1e-3
    w = 2 * np.pi / 10.0 * np.arange(1, 6)
    a, b = rng.normal(size=(2, 7, 5)) * 0.6 / (5 * np.arange(1, 6) ** 1.5)
    s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    q = s @ a.T + c @ b.T + np.linspace(-0.3, 0.3, 7)
    qd, qdd = (c * w) @ a.T - (s * w) @ b.T, -(s * w**2) @ a.T - (c * w**2) @ b.T
    tau = model.inverse_dynamics(q, qd, qdd)
    tau = tau + 0.02 * np.sqrt(np.mean(tau**2, axis=0)) * rng.normal(size=tau.shape)
    q = q + 1e-4 * rng.normal(size=q.shape)
    names = [f"q{j + 1}" for j in range(7)] + [f"tau{j + 1}" for j in range(7)]
    units = ["rad"] * 7 + ["N*m"] * 7
    return model, Recording(t, np.hstack([q, tau]), names, units)


def test_one_window_record_with_a_leftover_chunk_equals_in_memory_to_rounding(monkeypatch):
    # a record of one window, the last: from IN_PLACE_ND on its live columns are lifted in one
    # call, where chunks of COLUMNS (the rule below IN_PLACE_ND) would leave a last chunk of
    # fewer than LIFT_MIN_WORK / nd columns to plain sosfilt; the in-memory fit (chunks of 256)
    # lifts them all too: the same estimate to rounding
    import physid.estimators.idim.decimation as dm
    import physid.estimators.idim.stream_window as sw
    from physid.filters.lifted import LIFT_MIN_WORK

    model, rec = _arm7_record(9.0)
    nd = 45
    assert nd >= sw.IN_PLACE_ND and rec.n_samples < 65536  # one window
    chunks, inner = [], dm.lifting_pays

    def spy(nd_, n_samples, n_columns):
        chunks.append(n_columns)
        return inner(nd_, n_samples, n_columns)

    monkeypatch.setattr(dm, "lifting_pays", spy)
    ref = _fit(model, rec, decimate=nd)
    monkeypatch.setattr(dm, "lifting_pays", inner)
    # the in-memory fit lifts the live columns in one chunk; in chunks of COLUMNS the last
    # would hold too few to lift
    assert len(chunks) == 1 and (chunks[0] % sw.COLUMNS) * nd < LIFT_MIN_WORK
    inner_window, calls = sw.decimated_window, []

    def window_spy(sos, rows, *args):
        calls.append((rows.shape[1], args[-2]))  # columns read, lift
        return inner_window(sos, rows, *args)

    monkeypatch.setattr(sw, "decimated_window", window_spy)
    got = fit_streamed(model, rec, decimate=nd, progress=False)
    # the one window makes one lifted call over every live column
    assert len(calls) == 1 and calls[0][1] is True and calls[0][0] >= chunks[0]
    _same(ref, got, beta_rtol=1e-9)  # a parameter of 6e-4: 4e-10 of it (2e-13 absolute)
    b1, b2 = ref.beta_vector(), got.beta_vector()
    # measured: 2.4e-13 with earlier builds, 1.5e-12 with numpy 2.4.6 and scipy 1.17.1:
    # rounding, which cannot tell the path; the spies above check that it is one lifted call
    assert np.linalg.norm(b2 - b1) / np.linalg.norm(b1) < 5e-12


def test_a_column_that_becomes_live_mid_record_clears_the_carried_blocks(arm, rec, monkeypatch):
    # the last torque is exactly zero until 7 s (of 8), so the window where it
    # turns non-zero filters one more column: the lifted blocks carried from the previous
    # window (of fewer columns) are dropped and computed afresh; carried or never carried,
    # the same estimate bit for bit, and the in-memory one to rounding
    import physid.estimators.idim.stream_window as sw

    data = rec.data.copy()
    data[:7000, rec.names.index(f"tau{arm.n_joints}")] = 0.0
    late = Recording(rec.t, data, rec.names, rec.units)
    inner, calls = sw.decimated_window, []

    def spy(sos, rows, c0, c1, pos, first, count, nd, state, n_full, padlen, lift, carry):
        calls.append((rows.shape[1], carry is not None and "Z" in carry))
        return inner(sos, rows, c0, c1, pos, first, count, nd, state, n_full, padlen, lift, carry)

    def never(*args):
        return inner(*args[:-1], None)

    nd = sw.IN_PLACE_ND + 10
    monkeypatch.setattr(sw, "decimated_window", spy)
    got = fit_streamed(arm, ArrayBlocks(late), decimate=nd, block_samples=500, progress=False)
    widths = [w for w, _ in calls]
    grown = [i for i in range(1, len(calls)) if widths[i] > widths[i - 1]]
    assert len(grown) == 1 and not calls[grown[0]][1]  # the carry cleared where it grew
    assert calls[grown[0] - 1][1] and calls[grown[0] + 1][1]  # carried before and after
    monkeypatch.setattr(sw, "decimated_window", never)
    fresh = fit_streamed(arm, ArrayBlocks(late), decimate=nd, block_samples=500, progress=False)
    assert np.array_equal(got.beta_vector(), fresh.beta_vector())
    _same(_fit(arm, late, decimate=nd), got)


def test_a_long_state_filter_given_explicitly_caps_the_automatic_decimation(arm):
    """A half-width that leaves 1600 of 4000 samples: every candidate still fits (before, the
    largest assumed the default filter's three quarters and was refused), alike streamed."""
    rec = _run(arm, 4.0)
    settings = dict(cutoff=0.5, half_width=1200)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = IDIMEstimator(arm, **settings).fit(rec).result_
        got = fit_streamed(arm, rec, block_samples=1024, progress=False, **settings)
    assert "chosen by a 5-fold cross-validated torque error" in ref.message
    judged = int(ref.message.split("judged on the rows of decimate ")[1].split(";")[0])
    # 1600 samples after the filter, 24·nd lost to the parallel filter's ends, ≥ 50 rows left
    assert 24 * judged + 50 * judged <= 1600 and ref.n_rows >= 50
    assert got.decimate == ref.decimate and got.n_rows == ref.n_rows
    np.testing.assert_allclose(got.beta_vector(), ref.beta_vector(), rtol=1e-9)
