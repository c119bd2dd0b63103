"""Fleets (physid.analysis.fleet, fleet_result, report.fleet): one IDIM fit per log.

Kinds of test: equivalence of forms (serial, a LocalCluster, a tcp:// scheduler and a Client give
the same rows, in the order of the paths; a killed worker's task is rerun and its row equals the
serial one), an analytic cross-check (a changed link mass moves the base parameters by the amount
the base-parameter map predicts, and the moved test flags it), seeded statistics with the stated
z = 1.96 (an unchanged robot is not flagged), error paths (pytest.raises(..., match=...)), and the
written outputs read back (CSV, Parquet, the result files through physid validate).
"""

from __future__ import annotations

import csv
import functools
import json
import logging
import os
from pathlib import Path

import numpy as np
import pytest

import physid
from _fleet_logs import MODEL, write_log
from physid.analysis.fleet import fit_one_log, map_on_dask, run_fleet
from physid.analysis.fleet_result import Z_MOVED, Reference
from physid.errors import DataFileError, InputError, OutputError, SchedulerError
from physid.estimators.idim import base_regressor_info
from physid.estimators.results import save_result
from physid.report.fleet import write_fleet_report

distributed = pytest.importorskip("distributed", reason="the Dask tests need physid[dask]")

M2_NOMINAL = 1.1  # tests/data/planar2.urdf: link 2's mass [kg]
M2_PAYLOAD = 1.5


@pytest.fixture(scope="module")
def model():
    return physid.load_model(MODEL)


@pytest.fixture(scope="module")
def logs(tmp_path_factory, model):
    folder = tmp_path_factory.mktemp("fleet")
    paths = [write_log(folder / f"robot{k}.npz", model, seed=k) for k in range(3)]
    # the fleet's re-identification: every robot runs the same exciting trajectory (seed 0);
    # only the noise differs, and one robot carries a heavier link 2
    same = write_log(folder / "same.npz", model, seed=0, noise_seed=2)
    payload = write_log(folder / "payload.npz", model, seed=0, noise_seed=3,
                        params={"m2": M2_PAYLOAD})  # fmt: skip
    return folder, paths, (same, payload)


@pytest.fixture(scope="module")
def cluster():
    cl = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )
    yield cl
    cl.close()


def _assert_same_rows(got, want):
    """Row for row equal: text, integers and flags exactly, numbers to 1e-12 relative (a worker
    runs a single-threaded BLAS, this process may not: the last bit of a sum can differ), the
    fit's wall time left out; the result files' parameters and standard errors likewise."""
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert set(g) == set(w)
        for key in w:
            if key in ("elapsed_s", "result"):
                continue
            a, b = g[key], w[key]
            if isinstance(b, float) and not isinstance(b, bool):
                assert a == pytest.approx(b, rel=1e-12, abs=0.0), key
            else:
                assert a == b, key
        if w.get("result") is not None:
            for part in ("parameters", "stderr"):
                assert g["result"][part] == pytest.approx(w["result"][part], rel=1e-12)


def test_serial_local_tcp_and_client_agree_row_for_row(logs, cluster):
    _, paths, _ = logs
    serial = run_fleet(MODEL, paths, scheduler="serial", progress=False)
    assert [r["log"] for r in serial.rows] == paths
    assert serial.success and all(r["status"] == "ok" for r in serial.rows)
    local = run_fleet(MODEL, paths, scheduler="local:2", progress=False)
    tcp = run_fleet(MODEL, paths, scheduler=cluster.scheduler_address, progress=False)
    with distributed.Client(cluster) as client:
        given = run_fleet(MODEL, paths, scheduler=client, progress=False)
    assert "LocalCluster (2 worker" in local.backend and cluster.scheduler_address in tcp.backend
    for other in (local, tcp, given):
        _assert_same_rows(other.rows, serial.rows)  # same order, same numbers
        for a, b in zip(other.results, serial.results, strict=True):
            assert a["parameters"] == pytest.approx(b["parameters"], rel=1e-12)


def test_rows_hold_the_fit(logs, model):
    _, paths, _ = logs
    row = fit_one_log(MODEL, paths[0])
    est = physid.estimators.idim.IDIMEstimator(model, "ols").fit(physid.load_recording(paths[0]))
    r = est.result_
    assert row["status"] == "ok" and row["n_samples"] == 4000
    assert row["duration"] == pytest.approx(3.999, abs=1e-12)
    assert row["decimate"] == r.decimate and row["cutoff"] == r.cutoff
    for name in r.names:
        assert row[name] == r.parameters[name] and row[name + "_se"] == r.stderr[name]
    assert row["result"]["parameters"] == r.to_dict()["parameters"]


def test_a_failing_log_is_a_row_and_the_others_fit(logs):
    folder, paths, _ = logs
    garbage = folder / "garbage.npz"
    garbage.write_bytes(b"not a zip file at all")
    model = physid.load_model(MODEL)
    short = write_log(folder / "short.npz", model, seed=3, duration=0.004)
    t = np.arange(0.0, 2.0, 1e-3)  # a robot that never moves: nothing excites its inertia
    q = np.full((t.size, 2), 0.3)
    tau = model.inverse_dynamics(q, 0 * q, 0 * q) + 0.01 * np.random.default_rng(0).normal(
        size=q.shape
    )
    still = folder / "still.npz"
    physid.signals.save_recording(
        physid.signals.Recording(t, np.column_stack([q, tau]), ["q1", "q2", "tau1", "tau2"]),
        still,
    )
    rec = physid.load_recording(paths[1])  # another joint set: joint 2 not logged
    one = folder / "one_joint.npz"
    physid.signals.save_recording(
        physid.signals.Recording(rec.t, rec.select(["q1", "tau1"]), ["q1", "tau1"]), one
    )
    fleet = [paths[0], str(folder / "missing.npz"), str(folder), str(garbage), short, str(still)]
    res = run_fleet(MODEL, [*fleet, str(one), paths[1]], scheduler="serial", progress=False)
    status = [r["status"] for r in res.rows]
    assert status == ["ok"] + ["failed"] * 6 + ["ok"]
    reasons = [r["reason"] for r in res.rows]
    assert "no such file" in reasons[1] and "is a folder" in reasons[2]
    assert "garbage.npz" in reasons[3]
    assert "the recording has 4 samples" in reasons[4]
    assert "nothing in the recording(s) excites" in reasons[5]
    assert "lacks channel(s) ['q2', 'tau2']" in reasons[6]
    assert not res.success
    assert "failed" in res.summary() and "missing.npz" in res.summary()


def test_an_unexpected_error_is_a_row_naming_its_type(logs):
    _, paths, _ = logs
    row = fit_one_log(MODEL, paths[0], fit_options={"no_such_option": 1})
    assert row["status"] == "failed" and row["reason"].startswith("unexpected TypeError")


def _dies_once(path, marker_dir, victim):
    """A fleet task whose worker process dies (os._exit) the first time it fits ``victim``."""
    marker = Path(marker_dir) / "died"
    if path == victim and not marker.exists():
        marker.write_text("x")
        os._exit(1)
    return fit_one_log(MODEL, path)


class _Bar:
    def __init__(self):
        self.done = 0

    def advance(self, n=1):
        self.done += n


def test_a_killed_worker_loses_no_row(logs, tmp_path):
    _, paths, _ = logs
    cl = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
        silence_logs=logging.CRITICAL,
    )  # fmt: skip
    try:
        with distributed.Client(cl) as client:
            task = functools.partial(_dies_once, marker_dir=str(tmp_path), victim=paths[1])
            bar = _Bar()
            rows = map_on_dask(client, task, paths, 2, bar)
    finally:
        cl.close()
    assert (tmp_path / "died").exists()  # the worker did die once
    assert bar.done == len(paths)
    direct = [fit_one_log(MODEL, p) for p in paths]  # the same task, in this process
    _assert_same_rows(rows, direct)
    assert all(r["status"] == "ok" for r in rows)


@pytest.fixture(scope="module")
def reference(logs, model, tmp_path_factory):
    """The reference fit: robot 0's log, saved as identify --save saves it."""
    _, paths, _ = logs
    est = physid.estimators.idim.IDIMEstimator(model, "ols").fit(physid.load_recording(paths[0]))
    path = tmp_path_factory.mktemp("ref") / "reference.json"
    save_result(est.result_, path, model=MODEL, recording=paths[0], model_options={})
    return str(path)


def test_against_flags_a_payload_change_and_not_an_unchanged_robot(logs, model, reference):
    """Robots on the reference's trajectory, other noise. Seeded, z = 1.96: over 40 noise seeds
    2 of 40 unchanged robots had one of their 6 base parameters flagged (seed 2 has none, its
    largest |Δ|/sqrt(se² + se_ref²) is 0.77); the payload (m2 1.1 -> 1.5 kg) moves mcx1R by
    0.4·l1 and YY1R by 0.4·l1², about 300 se."""
    _, _, (unchanged, payload) = logs
    res = run_fleet(MODEL, [unchanged, payload], scheduler="serial", against=reference,
                    progress=False)  # fmt: skip
    entries = res.moved()
    same = [e for e in entries if e["log"] == unchanged]
    heavy = {e["parameter"]: e for e in entries if e["log"] == payload}
    assert Z_MOVED == 1.96
    assert same and not any(e["moved"] for e in same)  # seeded: no false alarm at z = 1.96
    assert res.rows[0]["moved"] == ""
    # the change the base-parameter map predicts for m2: 1.1 -> 1.5 kg (analytic cross-check)
    info = base_regressor_info(model)
    theta = np.asarray(model.parameter_vector(None), dtype=float)
    heavier = theta.copy()
    heavier[list(model.parameter_names).index("m2")] = M2_PAYLOAD
    predicted = dict(zip(info.names, info.from_standard(heavier) - info.from_standard(theta),
                         strict=True))  # fmt: skip
    moved = [n for n, e in heavy.items() if e["moved"]]
    assert moved and set(moved) == {n for n, d in predicted.items() if abs(d) > 1e-9}
    for name in moved:  # the measured change is the predicted one, within 4 combined se
        e = heavy[name]
        assert abs(e["change"] - predicted[name]) < 4 * e["bound"] / Z_MOVED
    assert set(res.rows[1]["moved"].split(", ")) == set(moved)
    assert "moved" in res.summary() and moved[0] in res.summary()


def test_a_parameter_in_one_fit_only_is_not_comparable(logs, reference):
    _, paths, _ = logs
    res = run_fleet(MODEL, paths[:1], scheduler="serial", progress=False)
    ref = Reference(path="r.json", model="", parameters={"mcx2": 0.0, "other": 1.0},
                    stderr={"mcx2": 1e-3, "other": 0.1})  # fmt: skip
    entries = {e["parameter"]: e for e in res.moved(ref)}
    assert entries["other"]["moved"] is None and "only one" in entries["other"]["note"]
    assert entries["mcz1"]["moved"] is None  # in the fleet's fit only
    assert entries["mcx2"]["moved"] is True  # 0.187 vs 0 with se ~1e-3: moved
    with pytest.raises(InputError, match="reference"):
        res.moved()


def test_outputs_are_written_and_read_back(logs, reference, tmp_path, capsys):
    pa = pytest.importorskip("pyarrow.parquet", reason="Parquet needs physid[parquet]")
    _, paths, (unchanged, payload) = logs
    res = run_fleet(MODEL, [unchanged, payload, str(tmp_path / "missing.npz")],
                    scheduler="serial", against=reference, progress=False)  # fmt: skip
    out = tmp_path / "fleet"
    out.mkdir()
    (out / "notes.txt").write_text("mine")  # a user's file in the folder is left alone
    written = write_fleet_report(res, out)
    assert (out / "notes.txt").read_text() == "mine"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".fleet.partial")]
    with open(written["csv"], newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["log"] for r in rows] == [r["log"] for r in res.rows]
    assert float(rows[0]["mcx1R"]) == res.rows[0]["mcx1R"]  # written exactly (repr)
    table = pa.read_table(written["parquet"]).to_pylist()
    assert table[1]["mcx1R_se"] == res.rows[1]["mcx1R_se"] and table[2]["status"] == "failed"
    assert table[0]["success"] is True
    page = written["html"].read_text(encoding="utf-8")
    assert "payload.npz" in page and 'class="moved"' in page and "missing.npz" in page
    files = sorted(p.name for p in (out / "results").iterdir())
    assert files == ["payload.json", "same.json"]
    data = json.loads((out / "results" / "same.json").read_text())
    assert data["parameters"]["mcx1R"] == res.rows[0]["mcx1R"]
    from physid.cli import main

    assert main(["validate", str(out / "results" / "same.json"), paths[2], "--json"]) == 0
    check = json.loads(capsys.readouterr().out)  # the held-out log: 2 % noise, fitted to 2 %
    assert check["failures"] == [] and check["relative_error"]["overall"] < 0.01
    df = res.to_pandas()
    assert list(df.columns) == list(res.columns) and df.shape[0] == 3
    # the analysis stage alone writes the tables and result files, the page only when given
    bare = res.write(tmp_path / "bare")
    assert "html" not in bare and not (tmp_path / "bare" / "fleet.html").exists()
    assert (tmp_path / "bare" / "fleet.csv").read_text() == written["csv"].read_text()


def test_write_refuses_a_link_in_the_folder_and_leaves_it_whole(logs, tmp_path):
    _, paths, _ = logs
    res = run_fleet(MODEL, paths[:1], scheduler="serial", progress=False)
    out = tmp_path / "fleet"
    out.mkdir()
    (tmp_path / "elsewhere.csv").write_text("keep")
    os.symlink(tmp_path / "elsewhere.csv", out / "fleet.csv")
    with pytest.raises(OutputError, match="fleet.csv"):
        res.write(out)
    assert (tmp_path / "elsewhere.csv").read_text() == "keep"
    assert sorted(p.name for p in out.iterdir()) == ["fleet.csv"]


def test_same_stems_get_distinct_result_files(logs, tmp_path, model):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = write_log(tmp_path / "a" / "log.npz", model, seed=1)
    b = write_log(tmp_path / "b" / "log.npz", model, seed=2)
    res = run_fleet(MODEL, [a, b], scheduler="serial", progress=False)
    assert [r["result_file"] for r in res.rows] == ["results/log.json", "results/log-2.json"]


def test_different_sampling_periods_fit_each_and_say_so(tmp_path, model):
    a = write_log(tmp_path / "fast.npz", model, seed=1, dt=1e-3)
    b = write_log(tmp_path / "slow.npz", model, seed=2, dt=2e-3, duration=6.0)
    res = run_fleet(MODEL, [a, b], scheduler="serial", progress=False)
    assert [r["status"] for r in res.rows] == ["ok", "ok"]
    assert [r["dt"] for r in res.rows] == [1e-3, 2e-3]
    assert any("different sampling periods" in n for n in res.notes)


def test_bad_arguments_are_refused(logs, tmp_path, model):
    _, paths, _ = logs
    with pytest.raises(InputError, match="paths is empty"):
        run_fleet(MODEL, [], progress=False)
    with pytest.raises(InputError, match="list of log files"):
        run_fleet(MODEL, paths[0], progress=False)
    with pytest.raises(InputError, match="model name or model file path"):
        run_fleet(model, paths, progress=False)
    with pytest.raises(InputError, match="method of a fleet"):
        run_fleet(MODEL, paths, method="input-error", progress=False)
    with pytest.raises(InputError, match="local:N"):
        run_fleet(MODEL, paths, scheduler="local:0", progress=False)
    with pytest.raises(DataFileError, match=r"against.*not a physid result file"):
        bad = tmp_path / "bad.json"
        bad.write_text('{"hello": 1}')
        run_fleet(MODEL, paths, against=bad, progress=False)
    with pytest.raises(DataFileError, match=r"against.*another model"):
        other = tmp_path / "other.json"
        other.write_text(json.dumps({"parameters": {"m1": 1.0, "l1": 0.4}}))
        run_fleet(MODEL, paths, against=other, progress=False)


def test_an_unreachable_scheduler_is_named(logs):
    _, paths, _ = logs
    with pytest.raises(
        SchedulerError, match=r"Dask scheduler at 'tcp://127\.0\.0\.1:9' within 2 s"
    ):
        run_fleet(MODEL, paths, scheduler="tcp://127.0.0.1:9", scheduler_timeout=2,
                  progress=False)  # fmt: skip
