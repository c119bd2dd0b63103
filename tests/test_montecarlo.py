"""Monte-Carlo sweeps: seeding, backends (in-process, pool, Dask), failures, atomic output."""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from physid.analysis import montecarlo as mc
from physid.analysis import sweep_table
from physid.analysis.msd_study import msd_sweep
from physid.errors import InputError

GRID = {"mu": [0.0, 2.0, -1.0], "sigma": [0.5, 1.0]}


# --------------------------------------------------------------------------- toy trials (picklable)
def toy_trial(settings, seed):
    """Sample mean and standard deviation of 200 normal draws: known expectations."""
    x = np.random.default_rng(seed).normal(settings["mu"], settings["sigma"], 200)
    return {"mean": x.mean(), "std": x.std(ddof=1), "label": f"mu={settings['mu']}"}


def failing_trial(settings, seed):
    if settings["mu"] == 2.0 and settings["sigma"] == 1.0:
        raise FloatingPointError("made to fail for this cell")
    return toy_trial(settings, seed)


def soft_failing_trial(settings, seed):
    out = toy_trial(settings, seed)
    if settings["mu"] < 0:
        out.update(status="estimator-failed", message="no excitation")
    return out


def killing_trial(settings, seed):
    """Kills its own worker process the first time it runs trial 0 of the first cell."""
    flag = Path(settings["flag"])
    if settings["mu"] == 0.0 and settings["sigma"] == 0.5 and not flag.exists():
        flag.write_text("killed once")
        os._exit(1)
    return toy_trial(settings, seed)


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip(
        "distributed", reason="Dask is an optional extra (physid[dask])"
    )
    import logging

    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


def _strip(rows):
    return [dict(r) for r in rows]


# --------------------------------------------------------------------------- seeds
def test_seeds_equal_nested_spawn_and_depend_only_on_grid_position():
    specs = mc.trial_specs(GRID, trials=4, seed=123)
    assert len(specs) == 3 * 2 * 4
    spec = specs[(2 * 2 + 1) * 4 + 3]  # mu index 2, sigma index 1, trial 3
    assert spec.settings == {"mu": -1.0, "sigma": 1.0} and spec.trial == 3
    nested = np.random.SeedSequence(123).spawn(3)[2].spawn(2)[1].spawn(4)[3]
    assert spec.seed == int(nested.generate_state(1, np.uint64)[0])
    assert len({s.seed for s in specs}) == len(specs)  # every trial its own stream
    # adding a value at the END of an axis leaves the existing trials' seeds unchanged
    bigger = mc.trial_specs({"mu": [0.0, 2.0, -1.0, 7.0], "sigma": [0.5, 1.0]}, trials=4, seed=123)
    by_key = {s.spawn_key: s.seed for s in bigger}
    assert all(by_key[s.spawn_key] == s.seed for s in specs)


def test_shared_seed_axes_give_the_same_data_to_every_setting_along_them():
    specs = mc.trial_specs(GRID, trials=2, seed=5, shared_seed_axes=("sigma",))
    seeds = {}
    for s in specs:
        seeds.setdefault((s.settings["mu"], s.trial), set()).add(s.seed)
    assert all(len(v) == 1 for v in seeds.values())
    assert len({next(iter(v)) for v in seeds.values()}) == 3 * 2


def test_mapping_valued_axis_merges_its_keys_into_the_settings():
    variants = [{"method": "a", "window": 0.1}, {"method": "b", "forgetting": 0.9}]
    specs = mc.trial_specs({"snr": [1, 2], "est": variants}, trials=1, seed=0)
    assert specs[1].settings == {"snr": 1, "method": "b", "forgetting": 0.9}


# --------------------------------------------------------------------------- results and backends
def test_serial_sweep_statistics_match_the_distribution():
    res = mc.run_sweep(toy_trial, GRID, trials=40, seed=1, scheduler="serial", progress=False)
    assert res.success and len(res.rows) == 240
    assert res.columns[:6] == ("index", "mu", "sigma", "trial", "seed", "spawn_key")
    assert res.columns[-2:] == ("status", "message")
    for cell in res.summarize():
        stats = cell["mean"]
        # mean of 40 sample means of 200 draws: standard error sigma / sqrt(8000)
        assert abs(stats["mean"] - cell["mu"]) < 4 * cell["sigma"] / math.sqrt(8000)
        assert cell["std"]["median"] == pytest.approx(cell["sigma"], rel=0.05)
        assert cell["n"] == cell["n_ok"] == 40
        assert "label" not in cell  # text outputs are not summarised


def test_local_pool_and_dask_give_identical_tables(dask_client):
    serial = mc.run_sweep(toy_trial, GRID, trials=5, seed=9, scheduler="serial", progress=False)
    pool = mc.run_sweep(
        toy_trial, GRID, trials=5, seed=9, scheduler="local", workers=2, progress=False
    )
    dask = mc.run_sweep(
        toy_trial, GRID, trials=5, seed=9, scheduler=dask_client, chunksize=3, progress=False
    )
    assert "process pool" in pool.backend and "dask" in dask.backend
    assert serial.to_csv_text() == pool.to_csv_text() == dask.to_csv_text()
    assert _strip(serial.rows) == _strip(dask.rows)


def test_same_seed_same_bits_other_seed_other_bits():
    a = mc.run_sweep(toy_trial, GRID, trials=3, seed=4, scheduler="serial", progress=False)
    b = mc.run_sweep(toy_trial, GRID, trials=3, seed=4, scheduler="serial", progress=False)
    c = mc.run_sweep(toy_trial, GRID, trials=3, seed=5, scheduler="serial", progress=False)
    assert a.to_csv_text() == b.to_csv_text()
    assert np.array_equal(a.column("mean"), b.column("mean"))
    assert not np.any(a.column("mean") == c.column("mean"))


def test_a_trial_that_raises_is_recorded_not_fatal():
    res = mc.run_sweep(
        failing_trial,
        GRID,
        trials=2,
        seed=0,
        scheduler="local",
        workers=2,
        chunksize=1,
        progress=False,
    )
    bad = [r for r in res.rows if r["status"] != "ok"]
    assert len(res.rows) == 12 and len(bad) == 2
    assert all(r["mu"] == 2.0 and r["sigma"] == 1.0 for r in bad)
    assert all(r["message"] == "FloatingPointError: made to fail for this cell" for r in bad)
    assert all(r["mean"] is None for r in bad)
    assert not res.success and "2 not ok" in res.message
    ok = [r for r in res.rows if r["status"] == "ok"]
    assert all(np.isfinite(r["mean"]) for r in ok)


def test_a_trial_may_report_its_own_status():
    res = mc.run_sweep(
        soft_failing_trial, GRID, trials=1, seed=0, scheduler="serial", progress=False
    )
    assert res.status_counts() == {"ok": 4, "estimator-failed": 2}
    cell = [c for c in res.summarize() if c["mu"] == -1.0][0]
    assert cell["n"] == 1 and cell["n_ok"] == 0 and "mean" not in cell


def test_a_killed_dask_worker_costs_no_trial(dask_client, tmp_path):
    flag = tmp_path / "killed.flag"
    grid = {**GRID, "flag": [str(flag)]}
    res = mc.run_sweep(
        killing_trial, grid, trials=2, seed=3, scheduler=dask_client, chunksize=2, progress=False
    )
    assert flag.exists(), "the trial did not kill its worker: the test would prove nothing"
    assert res.success and len(res.rows) == 12
    ref = mc.run_sweep(toy_trial, grid, trials=2, seed=3, scheduler="serial", progress=False)
    assert res.column("mean").tolist() == ref.column("mean").tolist()


def test_a_crashed_local_pool_worker_is_restarted(tmp_path):
    flag = tmp_path / "killed.flag"
    grid = {**GRID, "flag": [str(flag)]}
    res = mc.run_sweep(
        killing_trial,
        grid,
        trials=2,
        seed=3,
        scheduler="local",
        workers=2,
        chunksize=2,
        progress=False,
    )
    assert flag.exists() and res.success and len(res.rows) == 12
    ref = mc.run_sweep(toy_trial, grid, trials=2, seed=3, scheduler="serial", progress=False)
    assert res.to_csv_text() == ref.to_csv_text()


def test_progress_bar_goes_to_stderr(capsys):
    mc.run_sweep(toy_trial, GRID, trials=2, seed=0, scheduler="serial", progress=True, label="toy")
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "toy [" in captured.err and "12/12 trials" in captured.err


# --------------------------------------------------------------------------- output files
def test_write_sweep_outputs_round_trip(tmp_path):
    res = mc.run_sweep(failing_trial, GRID, trials=3, seed=2, scheduler="serial", progress=False)
    paths = res.write(tmp_path / "out")
    rows = mc.read_table(paths["csv"])
    assert len(rows) == 18
    for back, orig in zip(rows, res.rows, strict=True):
        assert back["seed"] == orig["seed"] and back["status"] == orig["status"]
        if orig["status"] == "ok":
            assert back["mean"] == orig["mean"]  # floats are written exactly
    doc = json.loads(paths["summary"].read_text())  # strict JSON (NaN would fail allow_nan=False)
    assert doc["status_counts"] == {"ok": 15, "error": 3}
    cell = doc["cells"][0]
    means = [r["mean"] for r in res.rows if r["mu"] == 0.0 and r["sigma"] == 0.5]
    assert cell["mean"]["mean"] == pytest.approx(np.mean(means), rel=1e-14)
    assert cell["mean"]["std"] == pytest.approx(np.std(means, ddof=1), rel=1e-12)
    leftovers = [p.name for p in (tmp_path / "out").iterdir() if p.name.endswith(".tmp")]
    assert leftovers == []


def estimate_trial(settings, seed):
    """A biased, noisy estimator of a known truth: final = truth·(1 + bias) + N(0, spread)."""
    rng = np.random.default_rng(seed)
    truth = settings["truth"]
    return {
        "x_true": truth,
        "x_final": truth * (1 + settings["bias"]) + rng.normal(0.0, settings["spread"]),
    }


def test_summary_reports_bias_spread_and_rmse_of_final_estimates():
    grid = {"truth": [10.0], "bias": [0.0, 0.05], "spread": [0.2]}
    res = mc.run_sweep(estimate_trial, grid, trials=400, seed=4, scheduler="serial", progress=False)
    for cell in res.summarize():
        acc = cell["accuracy"]["x"]
        finals = np.array([r["x_final"] for r in res.select(bias=cell["bias"])])
        # against numpy on the same numbers
        assert acc["truth"] == 10.0 and acc["n"] == 400 and acc["n_missing"] == 0
        assert acc["bias"] == pytest.approx(finals.mean() - 10.0, abs=1e-12)
        assert acc["std"] == pytest.approx(finals.std(ddof=1), rel=1e-12)
        assert acc["rmse"] == pytest.approx(np.sqrt(np.mean((finals - 10.0) ** 2)), rel=1e-12)
        assert acc["relative_bias"] == pytest.approx(acc["bias"] / 10.0, rel=1e-12)
        # and against the distribution: bias = 10·b ± 4σ/√n, spread = σ within 4 standard errors
        assert abs(acc["bias"] - 10.0 * cell["bias"]) < 4 * 0.2 / math.sqrt(400)
        assert abs(acc["std"] - 0.2) < 4 * 0.2 / math.sqrt(2 * 399)
        assert acc["rmse"] ** 2 == pytest.approx(acc["bias"] ** 2 + acc["std"] ** 2 * 399 / 400)


def test_accuracy_needs_one_nonzero_truth_per_cell():
    grid = {"truth": [0.0], "bias": [0.0], "spread": [1.0]}
    res = mc.run_sweep(estimate_trial, grid, trials=3, seed=0, scheduler="serial", progress=False)
    assert "accuracy" not in res.summarize()[0]  # relative error undefined at truth 0


def test_parquet_table_round_trips_uint64_seeds(tmp_path):
    import pyarrow.parquet as pq  # the 'parquet' extra; `make test` installs it

    res = mc.run_sweep(failing_trial, GRID, trials=3, seed=2, scheduler="serial", progress=False)
    seeds = [r["seed"] for r in res.rows]
    assert max(seeds) >= 2**63  # the case that overflowed pyarrow's int64 inference
    paths = res.write(tmp_path / "out")
    table = pq.read_table(paths["parquet"])
    assert str(table.schema.field("seed").type) == "uint64"
    assert table.column("seed").to_pylist() == seeds  # exactly, every bit
    assert table.column_names == list(res.columns)
    assert table.column("mean").to_pylist() == [r["mean"] for r in res.rows]  # None where failed
    assert table.column("status").to_pylist() == [r["status"] for r in res.rows]
    doc = json.loads(paths["summary"].read_text())
    assert doc["outputs"] == {"csv": "written", "parquet": "written"}


def test_a_parquet_failure_is_recorded_and_the_rest_is_written(tmp_path, monkeypatch):
    import pyarrow.parquet  # noqa: F401 - the 'parquet' extra; `make test` installs it

    def broken(result):
        raise OverflowError("made to fail")

    monkeypatch.setattr(sweep_table, "_arrow_table", broken)
    res = mc.run_sweep(toy_trial, GRID, trials=1, seed=0, scheduler="serial", progress=False)
    from matplotlib.figure import Figure

    paths = res.write(tmp_path / "out", figures={"map": Figure()})
    assert "parquet" not in paths and paths["summary"].exists() and paths["figure:map"].exists()
    doc = json.loads(paths["summary"].read_text())
    assert doc["outputs"]["parquet"] == "not written: OverflowError: made to fail"
    assert not list((tmp_path / "out").glob("*.tmp")) and not list((tmp_path / "out").glob(".*"))


def test_atomic_write_gives_the_permissions_of_a_plain_open(tmp_path):
    old = os.umask(0o027)
    try:
        mc.atomic_write(tmp_path / "a.csv", lambda fh: fh.write("x\n"))
        (tmp_path / "b.csv").write_text("x\n")  # what open() gives under the same umask
    finally:
        os.umask(old)
    mode_a = (tmp_path / "a.csv").stat().st_mode & 0o777
    assert mode_a == 0o640 == (tmp_path / "b.csv").stat().st_mode & 0o777  # not mkstemp's 0o600


def test_atomic_write_leaves_no_partial_file_when_interrupted(tmp_path):
    target = tmp_path / "trials.csv"

    def boom(fh):
        fh.write("index,mu\n0,1.0\n")
        raise KeyboardInterrupt  # interrupted half-way

    with pytest.raises(KeyboardInterrupt):
        mc.atomic_write(target, boom)
    assert not target.exists() and list(tmp_path.iterdir()) == []
    target.write_text("old complete table\n")
    with pytest.raises(KeyboardInterrupt):
        mc.atomic_write(target, boom)
    assert target.read_text() == "old complete table\n"  # the previous file survives intact
    assert [p.name for p in tmp_path.iterdir()] == ["trials.csv"]


def test_summary_medians_of_convergence_times_are_censored():
    rows_times = [0.1, 0.2, math.nan, math.nan, math.nan]

    def timing_trial(settings, seed):
        return {"t_conv": rows_times[settings["k"]]}

    res = mc.run_sweep(
        timing_trial,
        {"k": [0, 1, 2, 3, 4]},
        trials=1,
        scheduler="serial",
        censored_columns=("t_conv",),
        progress=False,
    )
    assert res.column("t_conv")[:2].tolist() == [0.1, 0.2]
    cells = res.summarize()
    assert cells[0]["t_conv"]["converged_fraction"] == 1.0
    assert math.isnan(cells[2]["t_conv"]["median_censored"])


# --------------------------------------------------------------------------- errors
def test_missing_dask_gives_install_hint(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(mc.MissingDependencyError, match=r"pip install physid\[dask\]"):
        mc.run_sweep(toy_trial, GRID, scheduler="local:2", progress=False)


def test_bad_arguments_raise_clear_errors():
    with pytest.raises(InputError, match="'local:N' needs a worker count"):
        mc.parse_scheduler("local:zero")
    with pytest.raises(InputError, match="scheduler must be 'local', 'serial'"):
        mc.parse_scheduler("cluster")
    with pytest.raises(InputError, match="grid axis 'mu' must be a list of values"):
        mc.trial_specs({"mu": 1.0}, trials=1)
    with pytest.raises(InputError, match="grid axis 'mu' is empty"):
        mc.trial_specs({"mu": []}, trials=1)
    with pytest.raises(InputError, match="trials must be an integer >= 1"):
        mc.trial_specs(GRID, trials=0)
    with pytest.raises(InputError, match="seed must be a non-negative integer"):
        mc.trial_specs(GRID, trials=1, seed=-3)
    with pytest.raises(InputError, match="shared_seed_axes names unknown axes"):
        mc.trial_specs(GRID, trials=1, shared_seed_axes=("snr",))
    with pytest.raises(InputError, match="workers must be an integer >= 1"):
        mc.run_sweep(toy_trial, GRID, workers=0)
    with pytest.raises(InputError, match="applies to scheduler='local' only"):
        mc.run_sweep(toy_trial, GRID, scheduler="serial", workers=2)
    with pytest.raises(InputError, match="cannot be sent to worker processes"):
        mc.run_sweep(lambda s, seed: {}, GRID, trials=5, scheduler="local", workers=2)
    with pytest.raises(InputError, match="no column 'nope'"):
        mc.run_sweep(toy_trial, GRID, scheduler="serial", progress=False).column("nope")


def test_msd_sweep_refuses_a_bad_record_length_before_running():
    """Checked by the sweep itself, not only by the CLI: no sweep full of error rows."""
    with pytest.raises(InputError, match=r"duration must be finite and > 0"):
        msd_sweep([80.0], [1.0], trials=1, duration=-1.0, scheduler="serial", progress=False)
    with pytest.raises(InputError, match=r"dt must be finite and > 0"):
        msd_sweep([80.0], [1.0], trials=1, dt=0.0, scheduler="serial", progress=False)
    # a coarse dt is blamed on dt, not on a duration the caller never gave
    with pytest.raises(InputError, match=r"dt = 1 s leaves only 5 sample\(s\) in duration = 5 s"):
        msd_sweep([80.0], [1.0], trials=1, dt=1.0, scheduler="serial", progress=False)


# ------------------------------------------------------------------ memory check
def test_sweep_memory_check_goes_through_the_one_helper(monkeypatch):
    import physid._resources as resources
    from physid.analysis import montecarlo
    from physid.errors import InputError

    calls = []
    monkeypatch.setattr(resources, "available_memory", lambda: calls.append(1) or 10**9)
    montecarlo._check_memory({"snr_db": [25, 50]}, 83_333)  # 499,998,000 B ≤ half of 1 GB: runs
    with pytest.raises(InputError) as info:
        montecarlo._check_memory({"snr_db": [25, 50]}, 10**6)  # 2e6 trials × 3000 B = 6 GB
    text = str(info.value)
    assert text.startswith("a sweep of 2,000,000 trials (2 grid point(s) × trials = 1,000,000)")
    assert "needs about 6 GB of memory for its table (3000 B per trial)" in text
    assert "has 1 GB available (a sweep may use 50%)" in text
    assert "at most about 83,333 trials per point here" in text
    assert len(calls) == 2  # the sweep asked the shared helper, not a copy of its own


def test_check_memory_default_wording_and_units():
    from physid._resources import check_memory, format_bytes
    from physid.errors import InputError

    check_memory(5e8, what="x", fix="y", available=10**9)  # exactly half: allowed
    with pytest.raises(InputError, match=r"^x needs about 501 MB of memory, more than half of "):
        check_memory(5.01e8, what="x", fix="lower y", available=10**9)
    assert format_bytes(9e15) == "9 PB" and format_bytes(2.5e18) == "2.5 EB"
