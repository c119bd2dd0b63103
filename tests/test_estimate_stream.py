"""Linear-ODE estimators on records read in blocks (`fit_blocks`) and ``physid estimate --stream``:
the block fit equals the in-memory fit of the same record; settings that cannot stream refuse."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

import physid.signals.io as signals_io
from physid.cli import main
from physid.errors import EstimationError, IdentifiabilityError, InputError, SamplingError
from physid.estimators.algebraic import AlgebraicEstimator
from physid.estimators.algebraic import fit_blocks as algebraic_blocks
from physid.estimators.recursive import RecursiveLeastSquares
from physid.estimators.recursive import fit_blocks as recursive_blocks
from physid.signals import Recording, load_recording, save_recording
from physid.signals.blocks import RecordingBlocks, block_starts

N = 12000  # 12 s at 1 kHz
DT = 1e-3


def _msd(n=N, noise=0.01, seed=0, offset=0.0):
    """ẍ + 2 ẋ + 100 x = u, two sinusoids, white output noise (a share of x's spread)."""
    t = np.arange(n) * DT
    u = np.sin(10 * t) + 0.5 * np.sin(23 * t)
    x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    x = x + noise * np.std(x) * np.random.default_rng(seed).normal(size=n) + offset
    return Recording(t, np.c_[u, x], ["u", "x"])


@pytest.fixture(scope="module")
def record():
    return _msd()


class ListBlocks:
    """A block source that is not `RecordingBlocks`: copies of the arrays, counting its reads."""

    def __init__(self, rec):
        self.t_all, self.data = np.asarray(rec.t), rec.select(list(rec.names))
        self.n_samples, self.dt, self.t0 = rec.n_samples, DT, float(rec.t[0])
        self.names, self.units, self.metadata = tuple(rec.names), tuple(rec.units), {}
        self.largest = 0
        self.passes = 0

    def blocks(self, size, channels=None):
        self.passes += 1
        names = list(channels or self.names)
        cols = [self.names.index(c) for c in names]
        starts = block_starts(self.n_samples, size)
        for a, b in zip(starts[:-1], starts[1:], strict=True):
            self.largest = max(self.largest, b - a)
            yield Recording(self.t_all[a:b].copy(), self.data[a:b, cols].copy(), names)


def _rel(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b) / np.abs(b)))


def _same_final(streamed, batch, se_rtol=1e-8):
    """The final estimate (1e-9), standard errors, verdict and training fit agree."""
    names = list(batch.parameters)
    assert list(streamed.parameters) == names
    assert (
        _rel([streamed.parameters[k] for k in names], [batch.parameters[k] for k in names]) < 1e-9
    )
    assert streamed.success == batch.success
    assert (streamed.stderr is None) == (batch.stderr is None)
    assert streamed.stderr_reason is None or batch.stderr_reason is not None
    if batch.stderr is not None:
        assert (
            _rel([streamed.stderr[k] for k in batch.stderr], list(batch.stderr.values())) < se_rtol
        )
        assert np.allclose(streamed.final_covariance, batch.final_covariance, rtol=se_rtol, atol=0)
    for k in batch.derived:
        assert streamed.derived[k] == pytest.approx(batch.derived[k], rel=1e-9)
    assert streamed.fit_percent == pytest.approx(batch.fit_percent, rel=1e-9)
    assert streamed.valid_fraction == batch.valid_fraction


@pytest.mark.parametrize(
    ("settings", "size"),
    [
        ({}, 997),
        ({"bias_compensation": True}, 4099),
        ({"forgetting": 0.999, "covariance": "diagonal"}, 1501),
    ],
)
def test_rls_blocks_equal_the_in_memory_fit(record, settings, size):
    est = RecursiveLeastSquares("msd", **settings)
    batch = est.fit(record).result_
    streamed = recursive_blocks(est, RecordingBlocks(record), block_samples=size, keep=600)
    _same_final(streamed, batch)
    assert streamed.init_end == batch.init_end
    step = int(np.ceil(N / 600))  # 20
    assert streamed.estimates.shape[0] == len(range(0, N, step)) <= 600
    np.testing.assert_allclose(streamed.t, batch.t[::step], rtol=0, atol=1e-12)
    np.testing.assert_allclose(streamed.estimates, batch.estimates[::step], rtol=1e-8)
    np.testing.assert_allclose(streamed.covariance, batch.covariance[::step], rtol=1e-8)
    assert any("hold one sample in 20 of the 12000" in n for n in streamed.metadata["notes"])
    # the white-row standard errors kept for comparison agree too
    white, white_batch = (r.metadata["stderr_white_rows"] for r in (streamed, batch))
    assert _rel(list(white.values()), list(white_batch.values())) < 1e-8


def test_rls_blocks_from_another_source_read_in_blocks(record):
    est = RecursiveLeastSquares("msd")
    src = ListBlocks(record)
    streamed = recursive_blocks(est, src, block_samples=3001, keep=N)
    batch = est.fit(record).result_
    _same_final(streamed, batch)
    assert src.largest < 2 * 3001  # never more than a block at a time
    assert src.passes == 3
    np.testing.assert_allclose(streamed.estimates, batch.estimates, rtol=1e-8)  # keep ≥ n: all


def test_rls_blocks_of_a_record_with_a_withheld_interval(record):
    """The noise bias withholds the intervals: the reason is the in-memory fit's."""
    est = RecursiveLeastSquares("msd")
    batch = est.fit(record).result_
    assert batch.stderr is None  # θ2's errors-in-variables bias at 40 dB exceeds 0.5 se
    streamed = recursive_blocks(est, record, block_samples=2048, progress=False)
    assert streamed.stderr_reason == batch.stderr_reason


def test_rls_blocks_of_a_record_that_explains_nothing():
    """Pure noise: the block fit's training fit and verdict are the in-memory fit's."""
    rng = np.random.default_rng(3)
    t = np.arange(6000) * DT
    rec = Recording(t, np.c_[rng.normal(size=t.size), rng.normal(size=t.size)], ["u", "x"])
    est = RecursiveLeastSquares("msd")
    batch = est.fit(rec).result_
    streamed = recursive_blocks(est, rec, block_samples=1111, progress=False)
    assert not batch.success
    assert streamed.success is False
    assert streamed.message == batch.message
    assert streamed.fit_percent == pytest.approx(batch.fit_percent, rel=1e-9)


@pytest.mark.parametrize(
    ("settings", "size"),
    [
        ({"window": 0.05}, 997),
        ({"window": 0.08, "block": 3, "block_stride": 5, "final_fraction": 0.5}, 2501),
    ],
)
def test_algebraic_blocks_equal_the_in_memory_fit(record, settings, size):
    est = AlgebraicEstimator("msd", final="bias-compensated", **settings)
    batch = est.fit(record).result_
    streamed = algebraic_blocks(est, RecordingBlocks(record), block_samples=size, keep=700)
    _same_final(streamed, batch)
    step = int(np.ceil(N / 700))
    np.testing.assert_allclose(streamed.estimates, batch.estimates[::step], rtol=1e-10)
    assert np.array_equal(streamed.valid, batch.valid[::step])
    assert streamed.settings["streamed"] is True


def test_algebraic_blocks_from_another_source(record):
    est = AlgebraicEstimator("msd", final="bias-compensated")
    src = ListBlocks(record)
    streamed = algebraic_blocks(est, src, block_samples=4000, keep=N, progress=False)
    _same_final(streamed, est.fit(record).result_)
    assert src.largest < 8000


def _offset_model():
    """ẍ + θ1 ẋ + θ2 x = u, measured x + offset (the offset estimated)."""
    from physid.models.linear_ode import LinearODEModel

    values = {"theta2": 100.0, "theta1": 2.0, "b0": 1.0, "offset": 0.0}
    return LinearODEModel(
        "msd_offset", ("theta2", "theta1"), ("b0",), values, unknown=("theta1", "theta2"),
        output_offset="offset",
    )  # fmt: skip


def _lead_model():
    """ẍ + θ1 ẋ + θ2 x = u + b1 u̇ (b1 estimated): an input derivative in the realisation."""
    from physid.models.linear_ode import LinearODEModel

    values = {"theta2": 100.0, "theta1": 2.0, "b0": 1.0, "b1": 0.05}
    return LinearODEModel(
        "msd_lead", ("theta2", "theta1"), ("b0", "b1"), values, unknown=("theta1", "theta2", "b1")
    )


@pytest.mark.parametrize(
    ("model", "num", "offset"), [("offset", [1.0], 0.3), ("lead", [0.05, 1.0], 0)]
)
def test_block_fits_of_models_with_an_offset_or_an_input_derivative(model, num, offset):
    model = _offset_model() if model == "offset" else _lead_model()
    t = np.arange(N) * DT
    u = np.sin(10 * t) + 0.5 * np.sin(23 * t)
    x = signal.lsim((num, [1.0, 2.0, 100.0]), u, t)[1]
    x = x + 0.01 * np.std(x) * np.random.default_rng(1).normal(size=N) + offset
    rec = Recording(t, np.c_[u, x], ["u", "x"])
    for est, fit_blocks in (
        (RecursiveLeastSquares(model, bias_compensation=True), recursive_blocks),
        (AlgebraicEstimator(model, final="bias-compensated"), algebraic_blocks),
    ):
        batch = est.fit(rec).result_
        assert batch.success and batch.stderr is not None  # a case with intervals to compare
        _same_final(fit_blocks(est, rec, block_samples=1999, progress=False), batch)


def test_block_fits_refuse_what_cannot_stream(record):
    with pytest.raises(InputError, match="prefilter='butterworth'"):
        recursive_blocks(RecursiveLeastSquares("msd", prefilter="differential"), record)
    with pytest.raises(InputError, match="final='bias-compensated'.*in memory"):
        algebraic_blocks(AlgebraicEstimator("msd"), record)
    with pytest.raises(InputError, match="median"):
        algebraic_blocks(AlgebraicEstimator("msd", final="median"), record)
    with pytest.raises(InputError, match="block_samples"):
        recursive_blocks(RecursiveLeastSquares("msd"), record, block_samples=1)
    with pytest.raises(InputError, match="keep"):
        recursive_blocks(RecursiveLeastSquares("msd"), record, keep=0)
    with pytest.raises(InputError, match="RecursiveLeastSquares"):
        recursive_blocks(AlgebraicEstimator("msd"), record)
    with pytest.raises(InputError, match="Recording or a block source"):
        recursive_blocks(RecursiveLeastSquares("msd"), np.zeros((10, 2)))


def test_block_fits_run_the_whole_record_checks(record):
    t = np.asarray(record.t)
    same = Recording(t, np.c_[record["x"], 3.0 * record["x"]], ["u", "x"])
    with pytest.raises(EstimationError, match="same signal"):
        recursive_blocks(RecursiveLeastSquares("msd"), same, progress=False)
    with pytest.raises(EstimationError, match="same signal"):
        algebraic_blocks(AlgebraicEstimator("msd", final="bias-compensated"), same)
    settled = Recording(t, np.c_[np.ones_like(t), np.full_like(t, 0.01)], ["u", "x"])
    for fit in (
        lambda: RecursiveLeastSquares("msd").fit(settled),
        lambda: recursive_blocks(RecursiveLeastSquares("msd"), settled, progress=False),
    ):
        with pytest.raises(IdentifiabilityError, match="excitation"):
            fit()
    short = Recording(t[:250], record.select(["u", "x"])[:250], ["u", "x"])  # 10 rows after 240
    for fit in (
        lambda: RecursiveLeastSquares("msd").fit(short),
        lambda: recursive_blocks(RecursiveLeastSquares("msd"), short, block_samples=64),
    ):
        with pytest.raises(EstimationError, match="10 rows after the 240-sample"):
            fit()
    with pytest.raises(SamplingError, match="longer than the record"):
        algebraic_blocks(AlgebraicEstimator("msd", final="bias-compensated", window=0.5), short)


# ---------------------------------------------------------------- the command line


@pytest.fixture(scope="module")
def msd_file(tmp_path_factory):
    return save_recording(_msd(n=8000), tmp_path_factory.mktemp("stream") / "msd.csv")


@pytest.fixture
def blocks_from_file(monkeypatch):
    """`open_blocks` as the file readers give it: here the whole load as a block source."""

    def open_blocks(path, channels=None, *, rate=None, channel_defaults=None, **options):
        rec = load_recording(path, channels, rate=rate, channel_defaults=channel_defaults)
        return RecordingBlocks(rec)

    if not hasattr(signals_io, "open_blocks"):
        monkeypatch.setattr(signals_io, "open_blocks", open_blocks, raising=False)
    if not hasattr(signals_io, "in_memory_bytes"):
        size = lambda path: 3 * Path(path).stat().st_size  # noqa: E731 (a CSV's estimate)
        monkeypatch.setattr(signals_io, "in_memory_bytes", size, raising=False)


def _run(capsys, *argv):
    code = main(["estimate", *map(str, argv)])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize(
    "method", [["--method", "rls"], ["--method", "algebraic", "--final", "bias-compensated"]]
)
def test_cli_stream_on_prints_the_in_memory_estimates(msd_file, capsys, blocks_from_file, method):
    code, memory, _ = _run(capsys, msd_file, *method, "--stream", "off")
    code_s, streamed, err = _run(
        capsys, msd_file, *method, "--stream", "on", "--block-samples", 999
    )
    assert (code, code_s) == (0, 0)
    assert streamed == memory  # the same summary, digit for digit
    assert "theta2" in streamed
    assert "streamed: read in blocks of 999 samples" in err


def test_cli_stream_json_says_so(msd_file, capsys, blocks_from_file):
    _, out, _ = _run(capsys, msd_file, "--method", "rls", "--json", "--stream", "on")
    streamed = json.loads(out)
    _, out, _ = _run(capsys, msd_file, "--method", "rls", "--json")  # auto: a small file
    memory = json.loads(out)
    assert (streamed["streamed"], memory["streamed"]) == (True, False)
    for k, v in memory["parameters"].items():
        assert streamed["parameters"][k] == pytest.approx(v, rel=1e-9)


def test_cli_stream_auto_streams_a_record_too_large_for_memory(
    msd_file, capsys, blocks_from_file, monkeypatch
):
    from physid import _resources as resources

    monkeypatch.setattr(resources, "STREAM_ABOVE", 1000)  # 8000 samples × 400 B > 1 kB
    code, out, err = _run(capsys, msd_file, "--method", "rls", "--json")
    assert code == 0
    assert json.loads(out)["streamed"] is True
    assert "the in-memory fit would need about 3.2 MB" in err  # 8000 samples × 400 B
    # settings that cannot stream fit in memory, with a note
    code, out, err = _run(capsys, msd_file, "--method", "algebraic", "--json")
    assert (code, json.loads(out)["streamed"]) == (0, False)
    assert "but cannot stream: --final lstsq needs every window's estimate" in err


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--method", "algebraic"], "--final lstsq needs every window's estimate"),
        (["--method", "algebraic", "--final", "median"], "--final bias-compensated streams"),
        (["--method", "rls", "--resample"], "--resample interpolates the whole record"),
        (["--method", "rls", "--detrend"], "--detrend subtracts the whole record's mean"),
    ],
)
def test_cli_stream_on_refuses_what_cannot_stream(msd_file, capsys, argv, match):
    code, out, err = _run(capsys, msd_file, *argv, "--stream", "on")
    assert code == 2
    assert out == ""
    assert match in err
    assert "Traceback" not in err


def test_cli_block_samples_is_checked(msd_file, capsys, blocks_from_file):
    code, _, err = _run(capsys, msd_file, "--method", "rls", "--stream", "on", "--block-samples", 1)
    assert code == 2
    assert "--block-samples" in err


def test_block_fits_show_progress_of_the_samples_read(record, monkeypatch):
    import io

    from physid import _progress

    stream = io.StringIO()

    class Shown(_progress.Progress):
        def __init__(self, total, label, **kw):
            super().__init__(total, label, **{**kw, "delay": 0.0, "stream": stream, "force": True})

    monkeypatch.setattr(_progress, "Progress", Shown)
    recursive_blocks(RecursiveLeastSquares("msd"), record, block_samples=4000, progress=False)
    assert stream.getvalue() == ""  # progress=False: nothing
    recursive_blocks(RecursiveLeastSquares("msd"), record, block_samples=4000)
    last = stream.getvalue().rstrip("\n").rsplit("\r", 1)[-1]
    assert last.startswith(f"rls, streamed (3 passes): {3 * N}/{3 * N} samples read")
    stream.seek(0), stream.truncate()
    algebraic_blocks(
        AlgebraicEstimator("msd", final="bias-compensated"), record, block_samples=4000
    )
    assert f"algebraic, streamed (3 passes): {3 * N}/{3 * N} samples read" in stream.getvalue()
