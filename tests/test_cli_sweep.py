"""`physid sweep msd|MODEL.toml`: files written, table shape, reproducibility, errors, SIGTERM."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from physid.analysis.montecarlo import read_table
from physid.analysis.msd_study import msd_sweep
from physid.cli import main

ARGS = [
    "sweep",
    "msd",
    "--snr",
    "50",
    "--ratio",
    "1,10",
    "--trials",
    "2",
    "--duration",
    "1",
    "--scheduler",
    "serial",
    "--no-progress",
]


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    assert main([*ARGS, "--out", str(out)]) == 0
    return out


def test_sweep_writes_table_summary_and_maps(sweep_dir, capsys):
    rows = read_table(sweep_dir / "trials.csv")
    # 1 SNR x 2 Z x 2 estimators x 2 trials
    assert len(rows) == 8
    assert {r["method"] for r in rows} == {"algebraic", "rls"}
    assert all(r["status"] == "ok" for r in rows)
    # both estimators of a (Z, trial) see the same record: same seed
    by_key = {}
    for r in rows:
        by_key.setdefault((r["ratio"], r["trial"]), set()).add(r["seed"])
    assert all(len(seeds) == 1 for seeds in by_key.values()) and len(by_key) == 4
    # at 50 dB with Z = 10 both estimators end within 2 % of the true w0 = sqrt(400/3)
    for r in rows:
        assert r["omega0_true"] == pytest.approx(math.sqrt(400 / 3), rel=1e-12)
        if r["ratio"] == 10.0:
            assert r["final_error"] < 0.02
    summary = json.loads((sweep_dir / "summary.json").read_text())
    assert summary["status_counts"] == {"ok": 8}
    assert len(summary["cells"]) == 4
    assert summary["grid"]["snr_db"] == [50.0] and summary["trials"] == 2
    for name in ("convergence_first_hit.png", "convergence_settle.png"):
        assert (sweep_dir / name).stat().st_size > 1000
    # bias and spread of the final estimates against the truth, per cell
    for cell in summary["cells"]:
        rows_of = [r for r in rows if r["ratio"] == cell["ratio"] and r["method"] == cell["method"]]
        for name, truth in (
            ("omega0", math.sqrt(400 / 3)),
            ("theta2", 400 / 3),
            ("theta1", 0.05 / 3),
        ):
            acc = cell["accuracy"][name]
            finals = [r[f"{name}_final"] for r in rows_of]
            assert acc["truth"] == pytest.approx(truth, rel=1e-12)
            assert acc["bias"] == pytest.approx(sum(finals) / 2 - truth, abs=1e-9 * truth)
            assert acc["std"] == pytest.approx(abs(finals[0] - finals[1]) / math.sqrt(2), rel=1e-9)


def test_sweep_writes_parquet_with_exact_seeds_and_readable_files(sweep_dir):
    import pyarrow.parquet as pq  # the 'parquet' extra; `make test` installs it

    rows = read_table(sweep_dir / "trials.csv")
    table = pq.read_table(sweep_dir / "trials.parquet")
    assert table.column("seed").to_pylist() == [r["seed"] for r in rows]
    assert table.column("omega0_final").to_pylist() == [r["omega0_final"] for r in rows]
    summary = json.loads((sweep_dir / "summary.json").read_text())
    assert summary["outputs"]["parquet"] == "written"
    # written atomically (mkstemp + rename), yet with the mode a plain open() gives
    from physid._paths import _current_umask

    expected = 0o666 & ~_current_umask()
    for path in sweep_dir.iterdir():
        assert path.stat().st_mode & 0o777 == expected, path.name


def test_same_seed_same_table_and_stdout_table(sweep_dir, tmp_path, capsys):
    assert main([*ARGS, "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "first hit [s]" in out and "algebraic T=0.05 s" in out and "RLS λ=1" in out
    assert (tmp_path / "trials.csv").read_bytes() == (sweep_dir / "trials.csv").read_bytes()


def test_json_output(tmp_path, capsys):
    args = [
        "sweep",
        "msd",
        "--snr",
        "80",
        "--ratio",
        "10",
        "--trials",
        "1",
        "--duration",
        "1",
        "--method",
        "rls",
        "--forgetting",
        "1,0.99",
        "--scheduler",
        "serial",
        "--no-progress",
        "--json",
        "--out",
        str(tmp_path),
    ]
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["success"] is True
    assert sorted(c["forgetting"] for c in doc["cells"]) == [0.99, 1.0]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--method", "kalman"], "--method expects a comma-separated list of algebraic, rls"),
        (["--snr", "high"], "--snr expects comma-separated numbers"),
        (["--scheduler", "cluster"], "scheduler must be 'local', 'serial', 'local:N'"),
        (["--trials", "0"], "--trials: expects a whole number >= 1"),
        (["--forgetting", "1.5"], r"--forgetting must lie in \(0, 1\]"),
    ],
)
def test_bad_options_exit_2_with_a_clear_message(tmp_path, capsys, extra, message):
    args = [
        "sweep",
        "msd",
        "--ratio",
        "10",
        "--trials",
        "1",
        "--duration",
        "1",
        "--out",
        str(tmp_path),
        "--no-progress",
        *extra,
    ]
    try:
        code = main(args)
    except SystemExit as exc:  # refused by argparse (e.g. --trials 0)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert "physid: error:" in err
    import re

    assert re.search(message, err)


def test_msd_sweep_pool_equals_serial_bit_for_bit():
    # (kept out of test_montecarlo.py, whose Dask client threads force a slower fork server)
    kw = dict(
        snr_db=[25.0, 80.0], ratio=[1.0, 10.0], trials=3, duration=1.0, seed=11, progress=False
    )
    pool = msd_sweep(**kw, scheduler="local", workers=2)
    serial = msd_sweep(**kw, scheduler="serial")
    assert "process pool" in pool.backend
    assert pool.to_csv_text() == serial.to_csv_text()
    assert pool.success and len(pool.rows) == 2 * 2 * 2 * 3


OSCILLATOR = """
name = "oscillator"
kind = "linear_ode"
description = "a lightly damped oscillator, w0 = 5 rad/s, input gain 2"
[parameters]
a0 = { value = 25.0, unit = "1/s^2", identify = true }
a1 = { value = 0.8, unit = "1/s", identify = true }
b0 = { value = 2.0, identify = false }
[ode]
a = ["a0", "a1"]
b = ["b0"]
input = "u"
output = "y"
"""


def test_sweep_of_a_model_file(tmp_path, capsys):
    """Any linear-ODE model file sweeps like the MSD: its own parameters, truths and maps."""
    model = tmp_path / "oscillator.toml"
    model.write_text(OSCILLATOR, encoding="utf-8")
    out = tmp_path / "out"
    args = ["sweep", str(model), "--snr", "60", "--ratio", "1,3", "--trials", "2"]
    args += ["--duration", "4", "--scheduler", "serial", "--no-progress", "--out", str(out)]
    assert main(args) == 0
    capsys.readouterr()
    rows = read_table(out / "trials.csv")
    assert len(rows) == 1 * 2 * 2 * 2 and {r["status"] for r in rows} == {"ok"}
    for r in rows:  # 60 dB: every estimator lands within 1 % of the file's nominal values
        assert r["a0_true"] == 25.0 and r["a1_true"] == 0.8
        assert abs(r["a0_final"] / 25.0 - 1) < 0.01, r
    assert (out / "convergence_settle.png").is_file()


def _worker_pids(pid: int) -> list[int]:
    """Child processes of ``pid`` running the same program (the pool's forked workers)."""
    try:
        me = Path(f"/proc/{pid}/cmdline").read_bytes()
        kids = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    except OSError:
        return []
    out = []
    for k in kids:
        try:
            if Path(f"/proc/{k}/cmdline").read_bytes() == me:
                out.append(int(k))
        except OSError:
            continue
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_sigterm_kills_the_pool_and_exits_143(tmp_path):
    """SIGTERM to `physid sweep --workers 2` leaves no worker behind and exits 143."""
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "physid", "sweep", "msd", "--workers", "2", "--trials", "500"]
    cmd += ["--snr", "25", "--ratio", "1", "--method", "rls", "--no-progress", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    workers: list[int] = []
    deadline = time.monotonic() + 180  # a guard against a hang, not a timing assertion
    while proc.poll() is None and time.monotonic() < deadline and len(workers) < 2:
        time.sleep(0.2)
        workers = _worker_pids(proc.pid)
    assert len(workers) == 2, f"the pool never started ({proc.poll()=})"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert "physid: terminated" in err and "Traceback" not in err
    deadline = time.monotonic() + 30
    while any(_alive(p) for p in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(p) for p in workers), "pool workers outlived the terminated sweep"
    assert not out.exists() or not any(out.iterdir())  # nothing half-written
