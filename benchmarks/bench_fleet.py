"""A fleet of logs, one IDIM-OLS fit per log, on Dask: 1 worker against 2, and a tcp:// scheduler.

The fleet: 16 one-minute logs at 1 kHz of physid's 6-DOF ``arm6`` (each robot a smooth 5-harmonic
Fourier motion of its own seed, torques from arm6's inverse dynamics plus 2 % noise, σ_q = 1e-4
rad), written to .npz in a temporary folder. Rows:

* the serial run (in-process), the reference for the results;
* a Dask LocalCluster of 1 and of 2 single-threaded worker processes (goal: 2 workers ≥ 1.8×
  faster than 1); each cluster is started and its workers load the model before the clock starts
  (the start-up is reported on its own row), so the ratio is that of the fits;
* a tcp:// scheduler the benchmark starts (a LocalCluster of 2 workers, reached by its address);
* the largest relative |Δ| between each Dask run's parameters and standard errors and the
  serial run's (goal ≤ 1e-12: the same fits; the last bit may differ where this process's BLAS
  is multi-threaded and the workers' is not).

The 1-minute load average is printed beside the ratio: on a shared machine other work takes the
second core and the ratio drops; the row says so rather than hiding it. ``--quick``: 4 logs of
10 s (timings not meant to be quoted).
"""

from __future__ import annotations

import logging
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from physid.analysis.fleet import fit_one_log, run_fleet
from physid.analysis.sweep_backends import dask_client

MODEL = "arm6"


def _write_logs(folder: Path, n: int, duration: float) -> list[str]:
    import physid
    from physid.signals import Recording, save_recording

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    try:
        from _fleet_logs import fourier_motion
    finally:
        sys.path.pop(0)
    model = physid.load_model(MODEL)
    t = np.arange(0.0, duration, 1e-3)
    names = [f"q{j + 1}" for j in range(6)] + [f"tau{j + 1}" for j in range(6)]
    paths = []
    for k in range(n):
        q, qd, qdd = fourier_motion(t, 6, seed=k)
        tau = model.inverse_dynamics(q, qd, qdd)
        rng = np.random.default_rng(100 + k)
        tau = tau + 0.02 * tau.std(axis=0) * rng.standard_normal(tau.shape)
        q = q + 1e-4 * rng.standard_normal(q.shape)
        folder.mkdir(exist_ok=True)
        path = folder / f"robot{k:02d}.npz"
        save_recording(Recording(t, np.column_stack([q, tau]), names), path)
        paths.append(str(path))
    return paths


def _max_delta(a, b) -> float:
    """Largest relative |Δ| over every parameter and standard error of two fleets' rows.

    Worker processes run a single-threaded BLAS (Dask's nanny sets OPENBLAS_NUM_THREADS=1) and
    this process may not: the sums of a product are then taken in another order, and the last
    bit of a result can differ (measured: 2.3e-16 on arm6). The goal is 1e-12 relative.
    """
    cols = [c for n in a.parameter_names for c in (n, n + "_se")]
    worst = 0.0
    for ra, rb in zip(a.rows, b.rows, strict=True):
        for c in cols:
            x, y = ra.get(c), rb.get(c)
            if x is None or y is None:
                if x is not y:
                    return float("inf")
                continue
            worst = max(worst, abs(x - y) / max(abs(x), abs(y), 1e-300))
    return worst


def _on_cluster(n_workers: int, paths: list[str], warm: str):
    """(start-up s, fleet) on a fresh LocalCluster; each worker fits the short log ``warm``
    first (model load, kernels), so that the timed run is the fleet's fits only."""
    start = time.perf_counter()
    with dask_client("dask-local", n_workers, 0.0) as (client, _):  # physid's own set-up
        client.run(fit_one_log, MODEL, warm)
        startup = time.perf_counter() - start
        return startup, run_fleet(MODEL, paths, scheduler=client, progress=False)


def _on_address(paths: list[str], warm: str):
    import distributed

    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )
    try:
        with distributed.Client(cluster) as client:
            client.run(fit_one_log, MODEL, warm)
        return run_fleet(MODEL, paths, scheduler=cluster.scheduler_address, progress=False)
    finally:
        cluster.close()


def run(quick: bool) -> list[dict]:
    n, duration = (4, 10.0) if quick else (16, 60.0)
    what = f"{n} logs x {duration:g} s at 1 kHz, arm6, idim-ols"
    try:
        import distributed  # noqa: F401
    except ImportError:
        return [{"case": f"fleet of {what}", "value": None, "unit": "",
                 "goal": "needs pip install physid[dask]", "met": None}]  # fmt: skip
    with tempfile.TemporaryDirectory(prefix="physid-fleet-") as tmp:
        paths = _write_logs(Path(tmp), n, duration)
        (warm,) = _write_logs(Path(tmp) / "warm", 1, 5.0)
        fit_one_log(MODEL, warm)  # this process too: model load and kernels, not timed
        serial = run_fleet(MODEL, paths, scheduler="serial", progress=False)
        load_before = os.getloadavg()[0]
        start1, one = _on_cluster(1, paths, warm)
        start2, two = _on_cluster(2, paths, warm)
        load_after = os.getloadavg()[0]
        tcp = _on_address(paths, warm)
    n_ok = sum(r["status"] == "ok" and bool(r["success"]) for r in serial.rows)
    cpus = os.cpu_count() or 1
    return [
        {"case": f"fleet of {what}: serial (in-process)", "value": serial.elapsed_s,
         "unit": "s"},
        {"case": "logs fitted with success (serial)", "value": n_ok, "unit": "logs",
         "goal": f"{n}", "met": n_ok == n},
        {"case": "Dask LocalCluster start-up and warm-up fit (1 / 2 workers, not timed below)",
         "value": start2, "unit": "s", "baseline": "1 worker", "baseline_value": start1},
        {"case": "Dask LocalCluster, 1 worker", "value": one.elapsed_s, "unit": "s",
         "baseline": "serial", "baseline_value": serial.elapsed_s,
         "ratio": serial.elapsed_s / one.elapsed_s},
        {"case": f"Dask LocalCluster, 2 workers vs 1 (1-min load average {load_before:.1f} "
                 f"before, {load_after:.1f} after, on {cpus} CPUs)",
         "value": two.elapsed_s, "unit": "s", "baseline": "1 Dask worker",
         "baseline_value": one.elapsed_s, "ratio": one.elapsed_s / two.elapsed_s,
         "goal": ">= 1.8x", "met": (one.elapsed_s / two.elapsed_s >= 1.8) if not quick else None},
        {"case": "tcp:// scheduler started here, 2 workers", "value": tcp.elapsed_s, "unit": "s",
         "baseline": "1 Dask worker", "baseline_value": one.elapsed_s,
         "ratio": one.elapsed_s / tcp.elapsed_s},
        {"case": "max relative |Δ| parameters and se, 2 workers vs serial", "value": _max_delta(two, serial),
         "unit": "", "goal": "<= 1e-12", "met": _max_delta(two, serial) <= 1e-12},
        {"case": "max relative |Δ| parameters and se, tcp:// vs serial", "value": _max_delta(tcp, serial),
         "unit": "", "goal": "<= 1e-12", "met": _max_delta(tcp, serial) <= 1e-12},
        {"case": "max relative |Δ| parameters and se, 1 worker vs serial", "value": _max_delta(one, serial),
         "unit": "", "goal": "<= 1e-12", "met": _max_delta(one, serial) <= 1e-12},
    ]  # fmt: skip
