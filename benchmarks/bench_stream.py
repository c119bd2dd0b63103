"""Long records in bounded memory: streamed IDIM-OLS on a 7-DOF arm, against the in-memory fit.

Data: ``tests/data/arm7.urdf`` (a Panda-like 7-DOF arm, physid's own file), a smooth 5-harmonic
Fourier motion per joint with a 10 s period, torques from the model's inverse dynamics plus white
noise of 2 % of each joint's rms, σ_q = 1e-4 rad, 1 kHz, written to HDF5 (``t``, ``q`` (n, 7),
``tau`` (n, 7)) block by block. The motion is periodic, so one period of the noise-free signals is
computed and tiled; the noise is drawn afresh for every block (seeded).

Rows
----
(a) Equality: the streamed fit against ``IDIMEstimator.fit`` of the same record loaded whole
    (largest relative difference of the base parameters; goal ≤ 1e-10) and the standard errors.
(b) Throughput [samples/s] of the streamed path (one core: BLAS and OpenMP limited to one thread)
    and of the in-memory path on the same record, measured in the same run; the ratio. Each is
    the best of ``--repeat`` fits in one process (default 3: on a shared machine one run's time
    varies by ±30 %), the first of them cold; each path in its own process, whose peak RSS is
    the peak over its fits (each result freed before the next fit).
(c) Time split of the streamed fit (read, state filter, regressor, parallel filter, accumulate,
    solve), so that the next bottleneck is visible.
(d) ``physid identify`` on the 1-hour record (3.6 M samples) in a fresh process on one core:
    wall time (goal ≤ 30 s) and peak RSS (goal ≤ 1 GB); with ``--hours 10`` also a 10-hour
    record: peak RSS the same, time linear in the length.

Usage: ``python benchmarks/bench_stream.py [--quick] [--hours 1,10] [--repeat 3]``; ``make bench``
runs the 1-hour case (``--quick``: a 2-minute record, every code path, no goals judged).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ARM7 = ROOT / "tests" / "data" / "arm7.urdf"
RATE = 1000.0  # Hz
PERIOD = 10.0  # s, the motion's fundamental period
HARMONICS = 5
SIGMA_Q = 1e-4  # rad
TORQUE_NOISE = 0.02  # of each joint's rms
ONE_CORE = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def one_period(model, seed: int = 0):
    """Noise-free q, τ of one period of the Fourier motion: arrays (n_period, 7) [rad], [N·m]."""
    rng = np.random.default_rng(seed)
    nj = int(model.n_joints)
    n = int(round(PERIOD * RATE))
    t = np.arange(n) / RATE
    w = 2.0 * np.pi / PERIOD * np.arange(1, HARMONICS + 1)  # rad/s
    a = rng.normal(size=(nj, HARMONICS)) / np.arange(1, HARMONICS + 1) ** 1.5
    b = rng.normal(size=(nj, HARMONICS)) / np.arange(1, HARMONICS + 1) ** 1.5
    scale = 0.6 / np.sum(np.abs(a) + np.abs(b), axis=1)  # |q - q0| ≤ 0.6 rad
    a, b = a * scale[:, None], b * scale[:, None]
    s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    q = s @ a.T + c @ b.T
    qd = (c * w) @ a.T - (s * w) @ b.T
    qdd = -(s * w**2) @ a.T - (c * w**2) @ b.T
    q0 = np.linspace(-0.3, 0.3, nj)
    tau = model.inverse_dynamics(q + q0, qd, qdd)
    return q + q0, tau


def write_record(path: Path, model, seconds: float, *, seed: int = 1, block: int = 1_000_000):
    """Write ``seconds`` of the noisy record to HDF5 in blocks; returns the number of samples."""
    import h5py

    q_p, tau_p = one_period(model)
    n_p = q_p.shape[0]
    n = int(round(seconds * RATE))
    nj = q_p.shape[1]
    sigma_tau = TORQUE_NOISE * np.sqrt(np.mean(tau_p**2, axis=0))
    rng = np.random.default_rng(seed)
    with h5py.File(path, "w") as f:
        t_ds = f.create_dataset("t", (n,), "f8", chunks=(min(n, 65536),))
        q_ds = f.create_dataset("q", (n, nj), "f8", chunks=(min(n, 65536), nj))
        tau_ds = f.create_dataset("tau", (n, nj), "f8", chunks=(min(n, 65536), nj))
        t_ds.attrs["unit"] = "s"
        q_ds.attrs["unit"] = "rad"
        tau_ds.attrs["unit"] = "N*m"
        for a in range(0, n, block):
            b = min(n, a + block)
            k = np.arange(a, b)
            t_ds[a:b] = k / RATE
            q_ds[a:b] = q_p[k % n_p] + SIGMA_Q * rng.standard_normal((b - a, nj))
            tau_ds[a:b] = tau_p[k % n_p] + sigma_tau * rng.standard_normal((b - a, nj))
    return n


def _run_child(argv, env_extra=None):
    """Run ``argv`` in a fresh process on one core; ``(wall s, returncode, stdout, stderr)``."""
    env = {**os.environ, **ONE_CORE, **(env_extra or {})}
    start = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    out, err = proc.communicate()
    wall = time.perf_counter() - start
    return wall, proc.returncode, out.decode(), err.decode()


# ru_maxrss of the waited children [kB on Linux] is the largest child so far, so each measured
# command runs under its own wrapper process, which reports its one child's peak
_MEASURE = r"""
import json, os, resource, subprocess, sys, time
argv = json.loads(sys.argv[1])
start = time.perf_counter()
proc = subprocess.run(argv, capture_output=True, text=True)
wall = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
print(json.dumps({"wall": wall, "peak": peak, "rc": proc.returncode,
                  "stdout": proc.stdout[-4000:], "stderr": proc.stderr[-4000:]}))
"""


def measure(argv) -> dict:
    """Wall time [s], peak RSS [bytes], exit status and output of ``argv`` on one core."""
    wall, rc, out, err = _run_child([sys.executable, "-c", _MEASURE, json.dumps(argv)])
    if rc != 0:
        raise RuntimeError(f"measuring {argv} failed: {err[-2000:]}")
    return json.loads(out)


def _fit_inline(kind: str, path: Path, repeat: int = 1) -> dict:
    """Fit ``path`` in this process (streamed or in memory) ``repeat`` times; estimate, stderr,
    seconds and split of the fastest fit."""
    import physid
    from physid.estimators.idim import IDIMEstimator
    from physid.estimators.idim.stream import fit_streamed
    from physid.signals.io import open_blocks

    model = physid.load_model(str(ARM7))
    best: dict = {"seconds": float("inf")}
    for _ in range(max(1, int(repeat))):  # the fastest of the fits
        times: dict = {}
        start = time.perf_counter()
        if kind == "stream":
            with open_blocks(path) as src:
                res = fit_streamed(model, src, method="ols", progress=False, timings=times)
        else:
            rec = physid.load_recording(path)
            res = IDIMEstimator(model, "ols").fit(rec).result_
            del rec
        elapsed = time.perf_counter() - start
        if elapsed < best["seconds"]:
            best = {
                "seconds": elapsed,
                "beta": [res.parameters[n] for n in res.names],
                "stderr": None if res.stderr is None else [res.stderr[n] for n in res.names],
                "success": bool(res.success),
                "decimate": int(res.decimate),
                "cutoff": float(res.cutoff),
                "timings": times,
            }
        del res  # not alive during the next fit
    return best


def _inline_in_child(kind: str, path: Path, repeat: int = 1) -> dict:
    here = str(Path(__file__).parent)
    code = (
        f"import json,sys; sys.path.insert(0, {here!r}); import bench_stream as b; "
        f"from pathlib import Path; "
        f"print(json.dumps(b._fit_inline({kind!r}, Path({str(path)!r}), {int(repeat)})))"
    )
    m = measure([sys.executable, "-c", code])
    out = json.loads(m["stdout"].strip().splitlines()[-1])
    out["peak"] = m["peak"]
    out["wall"] = m["wall"]
    return out


def _equality_rows(folder: Path, seconds: float, quick: bool, repeat: int = 1) -> list[dict]:
    import physid

    model = physid.load_model(str(ARM7))
    path = folder / "equal.h5"
    n = write_record(path, model, seconds)
    mem = _inline_in_child("memory", path, repeat)
    st = _inline_in_child("stream", path, repeat)
    b_m, b_s = np.array(mem["beta"]), np.array(st["beta"])
    norm = float(np.linalg.norm(b_s - b_m) / np.linalg.norm(b_m))
    worst = float(np.max(np.abs(b_s - b_m) / np.maximum(np.abs(b_m), 1e-300)))
    rows = [
        {
            "case": f"(a) streamed vs in-memory estimate, {seconds:g} s record: normwise",
            "value": norm,
            "unit": "||db||/||b||",
            "goal": "<= 1e-10",
            "met": None if quick else norm <= 1e-10,
        },
        {
            "case": "(a) the same, worst single parameter relative to its own value",
            "value": worst,
            "unit": "max |db|/|b|",
        },
    ]
    if mem["stderr"]:
        se = np.array(mem["stderr"])
        rows.append(
            {
                "case": "(a) the same, worst difference in units of the parameter's stderr",
                "value": float(np.max(np.abs(b_s - b_m) / np.maximum(se, 1e-300))),
                "unit": "max |db|/se",
            }
        )
    if mem["stderr"] and st["stderr"]:
        s_m, s_s = np.array(mem["stderr"]), np.array(st["stderr"])
        rows.append(
            {
                "case": "(a) streamed vs in-memory standard errors",
                "value": float(np.max(np.abs(s_s - s_m) / np.maximum(s_m, 1e-300))),
                "unit": "max rel diff",
            }
        )
    rate_s, rate_m = n / st["seconds"], n / mem["seconds"]
    rows.append(
        {
            "case": f"(b) streamed IDIM-OLS throughput, 7-DOF, one core, {n} samples, best "
            f"of {repeat}",
            "value": rate_s,
            "unit": "samples/s",
            "baseline": "in-memory IDIMEstimator.fit, same record",
            "baseline_value": rate_m,
            "ratio": rate_s / rate_m,
            "goal": ">= 200000 samples/s",
            "met": None if quick else rate_s >= 2e5,
        }
    )
    rows.append(
        {
            "case": f"(b) peak RSS streamed / in-memory, same record (peak over the {repeat} fits)",
            "value": st["peak"] / 2**20,
            "unit": "MiB",
            "baseline": "in-memory",
            "baseline_value": mem["peak"] / 2**20,
            "ratio": mem["peak"] / max(st["peak"], 1),
        }
    )
    total = sum(st["timings"].values()) or 1.0
    split = ", ".join(f"{k} {100 * v / total:.0f} %" for k, v in st["timings"].items())
    rows.append(
        {
            "case": f"(c) time split of the streamed fit: {split}",
            "value": total,
            "unit": "s",
        }
    )
    return rows


def _cli_rows(folder: Path, hours: list[float], quick: bool) -> list[dict]:
    import physid

    model = physid.load_model(str(ARM7))
    rows = []
    results = []
    for h in hours:
        path = folder / f"record_{h:g}h.h5"
        n = write_record(path, model, 3600.0 * h)
        argv = [
            sys.executable, "-m", "physid", "identify", str(path), "--model", str(ARM7),
            "--method", "idim-ols", "--json",
        ]  # fmt: skip
        m = measure(argv)
        path.unlink()
        results.append((h, n, m))
        rows.append(
            {
                "case": f"(d) physid identify, {h:g} h at 1 kHz ({n} samples), one core: time",
                "value": m["wall"],
                "unit": "s",
                "goal": "<= 30 s" if h == 1 else "linear in length",
                "met": None if quick or h != 1 else m["rc"] == 0 and m["wall"] <= 30.0,
            }
        )
        rows.append(
            {
                "case": f"(d) physid identify, {h:g} h: peak RSS (exit {m['rc']})",
                "value": m["peak"] / 2**30,
                "unit": "GiB",
                "goal": "<= 1 GiB",
                "met": None if quick else m["rc"] == 0 and m["peak"] <= 2**30,
            }
        )
    if len(results) > 1:
        (h0, n0, m0), (h1, n1, m1) = results[0], results[-1]
        rows.append(
            {
                "case": f"(d) time per sample, {h1:g} h over {h0:g} h",
                "value": (m1["wall"] / n1) / (m0["wall"] / n0),
                "unit": "ratio",
                "goal": "about 1 (linear)",
            }
        )
    return rows


def run(quick: bool = False, hours=(1.0,), repeat: int = 3) -> list[dict]:
    """The benchmark's rows (see the module docstring)."""
    with tempfile.TemporaryDirectory(prefix="physid-bench-stream-") as tmp:
        folder = Path(tmp)
        rows = _equality_rows(folder, 120.0 if quick else 600.0, quick, 1 if quick else repeat)
        rows += _cli_rows(folder, [2.0 / 60.0] if quick else list(hours), quick)
    return rows


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--hours", default="1", help="record lengths for row (d), e.g. 1,10")
    p.add_argument("--repeat", type=int, default=3, help="fits per path in row (b): the best")
    a = p.parse_args()
    for r in run(a.quick, [float(x) for x in a.hours.split(",")], a.repeat):
        print(r)
