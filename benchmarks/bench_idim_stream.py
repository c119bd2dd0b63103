"""Streamed IDIM against the in-memory fit on a 7-DOF arm: samples/s, time split, peak memory.

Data: the Franka Panda URDF (``../shared/data/real-robots/panda_gaz2019/panda_arm.urdf``, read
in place; ``--urdf`` for another), a smooth 5-harmonic Fourier motion of every joint at 1 kHz,
torques from the model's inverse dynamics plus white noise of 2 % of each joint's rms, encoder
noise σ_q = 1e-4 rad. Each fit runs in its own subprocess so that its peak RSS
(``resource.getrusage``) is its own.

Rows: ``fit_streamed`` (OLS, defaults) and ``IDIMEstimator(model, "ols").fit`` on the same
record: seconds, samples/s, peak RSS, the largest relative difference of the estimates; the
streamed fit's time split (read, state filter, regressor, parallel filter, accumulate, solve).

    python benchmarks/bench_idim_stream.py --samples 600000 [--quick]
    python benchmarks/bench_idim_stream.py --lazy --samples 1200000   # peak RSS vs length
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

URDF = Path(__file__).resolve().parents[3] / "shared/data/real-robots/panda_gaz2019/panda_arm.urdf"


def record(model, n: int, seed: int = 0):
    """A smooth 5-harmonic motion, its inverse-dynamics torques (+2 % noise), σ_q = 1e-4 rad."""
    from physid.signals.recording import Recording

    rng = np.random.default_rng(seed)
    nj = int(model.n_joints)
    t = np.arange(n) * 1e-3
    f0 = 0.1
    q = np.zeros((n, nj))
    qd = np.zeros((n, nj))
    qdd = np.zeros((n, nj))
    for k in range(1, 6):  # 5 harmonics
        w = 2 * np.pi * f0 * k
        a, b = rng.normal(0, 0.3 / k, nj), rng.normal(0, 0.3 / k, nj)
        s, c = np.sin(np.outer(t, w * np.ones(nj))), np.cos(np.outer(t, w * np.ones(nj)))
        q += a * s + b * c
        qd += w * (a * c - b * s)
        qdd += -(w**2) * (a * s + b * c)
    tau = np.empty((n, nj))
    for s0 in range(0, n, 50000):
        sl = slice(s0, s0 + 50000)
        tau[sl] = model.inverse_dynamics(q[sl], qd[sl], qdd[sl])
    tau += rng.normal(size=tau.shape) * 0.02 * np.sqrt(np.mean(tau**2, axis=0))
    q_meas = q + rng.normal(size=q.shape) * 1e-4
    names = [f"q{j + 1}" for j in range(nj)] + [f"tau{j + 1}" for j in range(nj)]
    units = ["rad"] * nj + ["N*m"] * nj
    return Recording(t, np.hstack([q_meas, tau]), names, units)


class LazyBlocks:
    """The same kind of record generated block by block (never whole in memory): a block
    source whose samples depend only on their index (noise drawn per 4096-sample chunk)."""

    def __init__(self, model, n: int, seed: int = 0):
        rng = np.random.default_rng(seed)
        self.model, self.n_samples, self.dt, self.t0, self.seed = model, n, 1e-3, 0.0, seed
        nj = int(model.n_joints)
        self.ab = [(rng.normal(0, 0.3 / k, nj), rng.normal(0, 0.3 / k, nj)) for k in range(1, 6)]
        self.names = tuple([f"q{j + 1}" for j in range(nj)] + [f"tau{j + 1}" for j in range(nj)])
        self.units = ("rad",) * nj + ("N*m",) * nj
        self.metadata = {}
        probe = self._clean(0, 20000)[1]
        self.tau_rms = np.sqrt(np.mean(probe**2, axis=0))

    def _clean(self, a, b):
        nj = int(self.model.n_joints)
        t = np.arange(a, b) * self.dt
        q, qd, qdd = np.zeros((b - a, nj)), np.zeros((b - a, nj)), np.zeros((b - a, nj))
        for k, (ca, cb) in enumerate(self.ab, start=1):
            w = 2 * np.pi * 0.1 * k
            s, c = np.sin(w * t)[:, None], np.cos(w * t)[:, None]
            q += ca * s + cb * c
            qd += w * (ca * c - cb * s)
            qdd += -(w**2) * (ca * s + cb * c)
        return t, self.model.inverse_dynamics(q, qd, qdd), q

    def _noise(self, a, b, width):
        chunks = [
            np.random.default_rng([self.seed, c]).normal(size=(4096, width))
            for c in range(a // 4096, (b - 1) // 4096 + 1)
        ]
        x = np.concatenate(chunks)
        return x[a - (a // 4096) * 4096 :][: b - a]

    def blocks(self, size, channels=None):
        from physid.signals.blocks import block_starts
        from physid.signals.recording import Recording

        nj = int(self.model.n_joints)
        starts = block_starts(self.n_samples, size)
        for a, b in zip(starts[:-1], starts[1:], strict=True):
            t, tau, q = self._clean(a, b)
            z = self._noise(a, b, 2 * nj)
            x = np.hstack([q + 1e-4 * z[:, :nj], tau + 0.02 * self.tau_rms * z[:, nj:]])
            names = list(channels or self.names)
            idx = [self.names.index(c) for c in names]
            yield Recording(t, x[:, idx], names, [self.units[i] for i in idx])


def _child(kind: str, urdf: str, n: int) -> None:
    import physid
    from physid.estimators.idim import IDIMEstimator, fit_streamed

    warnings.simplefilter("ignore")
    model = physid.load_model(urdf)
    rec = LazyBlocks(model, n) if kind == "lazy" else record(model, n)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    times: dict = {}
    tic = time.perf_counter()
    if kind in ("stream", "lazy"):
        res = fit_streamed(model, rec, progress=False, timings=times)
    else:
        res = IDIMEstimator(model, "ols").fit(rec).result_
    wall = time.perf_counter() - tic
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(
        json.dumps(
            {
                "wall": wall,
                "peak_mb": peak / 1024,
                "before_mb": base / 1024,
                "times": times,
                "beta": res.beta_vector().tolist(),
                "nd": res.decimate,
                "cutoff": res.cutoff,
                "success": res.success,
                "rows": res.n_rows,
            }
        )
    )


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=600_000)
    ap.add_argument("--urdf", default=str(URDF))
    ap.add_argument("--quick", action="store_true", help="60 000 samples")
    ap.add_argument("--child", choices=["stream", "memory", "lazy"])
    ap.add_argument(
        "--lazy", action="store_true", help="streamed fit only, of a record generated per block"
    )
    ap.add_argument("--no-memory", action="store_true", help="skip the in-memory fit")
    args = ap.parse_args(argv)
    n = 60_000 if args.quick else args.samples
    if args.child:
        _child(args.child, args.urdf, n)
        return
    out = {}
    kinds = ["lazy"] if args.lazy else ["stream"] + ([] if args.no_memory else ["memory"])
    for kind in kinds:
        cmd = [sys.executable, __file__, "--child", kind, "--urdf", args.urdf, "--samples", str(n)]
        done = subprocess.run(cmd, capture_output=True, text=True, check=True)
        out[kind] = json.loads(done.stdout.strip().splitlines()[-1])
    print(f"7-DOF {Path(args.urdf).name}, {n} samples at 1 kHz, IDIM-OLS defaults")
    print(f"{'fit':10s} {'s':>8s} {'samples/s':>11s} {'peak RSS MB':>12s} {'(data+model MB)':>16s}")
    for kind, r in out.items():
        print(
            f"{kind:10s} {r['wall']:8.2f} {n / r['wall']:11.0f} {r['peak_mb']:12.0f} "
            f"{r['before_mb']:16.0f}"
        )
    s = out.get("stream") or out["lazy"]
    if "memory" in out:
        m = out["memory"]
        b1, b2 = np.array(m["beta"]), np.array(s["beta"])
        print(
            f"speed ratio streamed/in-memory: {m['wall'] / s['wall']:.2f}; nd {s['nd']} vs "
            f"{m['nd']}; max |Δβ|/|β| = {np.max(np.abs(b1 - b2) / np.abs(b1)):.2e}"
        )
    print("time split (streamed): " + ", ".join(f"{k} {v:.2f} s" for k, v in s["times"].items()))


if __name__ == "__main__":
    main()
