"""Simulation speed: the paper's 9.7 s closed-loop run against pinocchio's ABA, and the exact MSD
simulation's throughput against scipy.signal.lsim.

Rows
----
* ``manipulator 9.7 s run``: the same `scipy.integrate.solve_ivp` run (DOP853, rtol 1e-9,
  atol 1e-11, t_eval on the 1 ms grid, identical reference spline and PD law) driven by our
  compiled right-hand side, by the model's generated Python code, and by ``pinocchio.aba`` on an
  equivalent pinocchio model; ratio = pinocchio time / ours (> 1: we are faster). Best of N.
* ``rhs call``: the cost of one right-hand-side evaluation [µs].
* ``msd exact simulation``: samples per second of `simulate_msd` (exact sinusoid, matrix
  exponential + Schur-basis lfilter recursion) against `scipy.signal.lsim` (first-order hold,
  Python loop over samples) on the same record; plus the accuracy against the closed form.
"""

from __future__ import annotations

import time
import timeit

import numpy as np
from _timing import best_time


def _manipulator_rows(quick: bool) -> list[dict]:
    from physid.models import load_model
    from physid.simulate import (
        PAPER_MANIPULATOR,
        ReferenceTrajectory,
        closed_loop_rhs,
        paper_manipulator_experiment,
        paper_reference,
    )

    model = load_model("manipulator", kinetic="exact")
    repeats = 1 if quick else 5
    end_time = 2.0 if quick else PAPER_MANIPULATOR["end_time"]
    rows = []
    try:
        import pinocchio  # noqa: F401

        have_pin = True
    except ImportError:
        have_pin = False
    backends = ["compiled", "generated"] + (["pinocchio"] if have_pin else [])
    times, nfev = {}, {}
    for backend in backends:  # warm up (compiles the C once) and check the backend really ran
        rec = paper_manipulator_experiment(model=model, backend=backend, end_time=end_time)
        nfev[backend] = rec.metadata["integrator"]["nfev"]
        times[backend] = np.inf if rec.metadata["integrator"]["backend"] == backend else np.nan
    for _ in range(repeats):  # interleaved, so that all backends see the same machine load
        for backend in backends:
            elapsed = best_time(
                lambda b=backend: paper_manipulator_experiment(
                    model=model, backend=b, end_time=end_time
                ),
                1,
            )
            times[backend] = min(times[backend], elapsed)
    base = times.get("pinocchio")
    for backend in ("compiled", "generated"):
        ratio = base / times[backend] if base else None
        rows.append(
            {
                "case": f"manipulator {end_time:g} s run, {backend} rhs ({nfev[backend]} calls)",
                "value": times[backend],
                "unit": "s",
                "baseline": "same solve_ivp run with pinocchio.aba" if base else None,
                "baseline_value": base,
                "ratio": ratio,
                "goal": "at least as fast as pinocchio (ratio >= 1)",
                "met": bool(ratio is not None and ratio >= 1.0),
            }
        )
    # one right-hand-side call
    ref = paper_reference()
    spline = ReferenceTrajectory(ref.t, ref.values)
    y = np.random.default_rng(0).standard_normal(8)
    per_call = {}
    for backend in backends:
        f = closed_loop_rhs(
            model,
            kp=PAPER_MANIPULATOR["kp"],
            kd=PAPER_MANIPULATOR["kd"],
            reference=spline,
            backend=backend,
        )
        number = 2000 if quick else 20000
        per_call[backend] = min(timeit.repeat(lambda f=f: f(1.2345, y), number=number, repeat=3))
        per_call[backend] *= 1e6 / number
    for backend in ("compiled", "generated"):
        base_call = per_call.get("pinocchio")
        rows.append(
            {
                "case": f"rhs call, {backend}",
                "value": per_call[backend],
                "unit": "us",
                "baseline": "pinocchio.aba rhs" if base_call else None,
                "baseline_value": base_call,
                "ratio": base_call / per_call[backend] if base_call else None,
                "goal": "informational",
                "met": None,
            }
        )
    return rows


def _msd_rows(quick: bool) -> list[dict]:
    from scipy.signal import lsim

    from physid.simulate import PAPER_MSD, simulate_msd

    n = 100_000 if quick else 1_000_000
    dt = PAPER_MSD["dt"]
    duration = (n - 1) * dt
    w0 = np.sqrt(PAPER_MSD["stiffness"] / PAPER_MSD["mass"])
    kwargs = dict(
        mass=PAPER_MSD["mass"],
        damping=PAPER_MSD["damping"],
        stiffness=PAPER_MSD["stiffness"],
        amplitude=PAPER_MSD["amplitude"],
        ratio=10.0,
        duration=duration,
        dt=dt,
    )
    repeats = 1 if quick else 3
    ours = best_time(lambda: simulate_msd(**kwargs), repeats)
    rec = simulate_msd(**kwargs)
    th1 = PAPER_MSD["damping"] / PAPER_MSD["mass"]
    th2 = w0**2
    lsim_n = min(n, 100_000)  # lsim loops in Python; extrapolate its per-sample cost
    t = rec.t[:lsim_n]
    u = rec["u"][:lsim_n]
    theirs = best_time(lambda: lsim(([1.0], [1.0, th1, th2]), u, t), 1) * n / lsim_n
    rows = [
        {
            "case": f"msd exact simulation, {n} samples",
            "value": n / ours,
            "unit": "samples/s",
            "baseline": "scipy.signal.lsim (first-order hold)",
            "baseline_value": n / theirs,
            "ratio": theirs / ours,
            "goal": ">= 1e6 samples/s (full run; --quick is too short to amortise setup)",
            "met": None if quick else bool(n / ours >= 1e6),
        }
    ]
    # accuracy of the paper scenario (Z = 1, resonance) against the closed form
    from physid.simulate import msd_paper_scenario

    paper = msd_paper_scenario(ratio=1.0)
    tt = paper.t
    a = PAPER_MSD["amplitude"]
    den = (th2 - w0**2) ** 2 + (th1 * w0) ** 2
    ps, pc = a * (th2 - w0**2) / den, -a * th1 * w0 / den
    sigma, wd = th1 / 2, np.sqrt(th2 - th1**2 / 4)
    c1 = -pc
    c2 = (-w0 * ps + sigma * c1) / wd
    exact = ps * np.sin(w0 * tt) + pc * np.cos(w0 * tt)
    exact += np.exp(-sigma * tt) * (c1 * np.cos(wd * tt) + c2 * np.sin(wd * tt))
    err = float(np.abs(paper["x"] - exact).max())
    rows.append(
        {
            "case": "msd paper scenario (Z = 1, 5 s) max |x - closed form|",
            "value": err,
            "unit": "m",
            "baseline": "max |x|",
            "baseline_value": float(np.abs(exact).max()),
            "ratio": None,
            "goal": "<= 1e-10 relative",
            "met": bool(err <= 1e-10 * np.abs(exact).max()),
        }
    )
    return rows


def _rigid_rows(quick: bool) -> list[dict]:
    """A 10 s closed-loop run of the 7-DOF Panda-like arm (armature, viscous and Coulomb
    friction), the same solve_ivp run driven by the C kernel and by pinocchio.aba."""
    from pathlib import Path

    from physid.models import load_model
    from physid.simulate import ReferenceTrajectory, simulate_closed_loop

    urdf = Path(__file__).resolve().parent.parent / "tests" / "data" / "arm7.urdf"
    model = load_model(urdf)
    duration = 2.0 if quick else 10.0
    t = np.arange(0.0, duration + 5e-4, 1e-3)
    amp = np.array([0.5, 0.4, 0.5, 0.4, 0.6, 0.5, 0.6])
    freq = 0.2 * (1.0 + 0.37 * np.arange(7))
    mid = np.array([0, 0, 0, -1.5, 0, 1.8, 0])
    ref = ReferenceTrajectory(t, mid + amp * np.sin(2 * np.pi * freq * t[:, None]))
    kp = np.array([600, 600, 500, 400, 100, 80, 50.0])
    kd = np.array([50, 50, 40, 30, 8, 6, 4.0])
    times, nfev = {}, {}
    repeats = 1 if quick else 3
    for backend in ("compiled", "pinocchio"):
        best = np.inf
        for _ in range(repeats):
            start = time.perf_counter()  # the recording keeps no wall time (byte-identical runs)
            rec = simulate_closed_loop(
                model, kp=kp, kd=kd, reference=ref, t=t, q0=mid, backend=backend
            )
            best = min(best, time.perf_counter() - start)
        times[backend] = best
        nfev[backend] = rec.metadata["integrator"]["nfev"]
    ratio = times["pinocchio"] / times["compiled"]
    return [
        {
            "case": f"7-DOF rigid {duration:g} s closed loop, C kernel ({nfev['compiled']} calls)",
            "value": times["compiled"],
            "unit": "s",
            "baseline": f"same solve_ivp run with pinocchio.aba ({nfev['pinocchio']} calls)",
            "baseline_value": times["pinocchio"],
            "ratio": ratio,
            "goal": "at least as fast as pinocchio (ratio >= 1)",
            "met": bool(ratio >= 1.0),
        }
    ]


def run(quick: bool = False) -> list[dict]:
    return _rigid_rows(quick) + _manipulator_rows(quick) + _msd_rows(quick)


if __name__ == "__main__":
    for row in run(quick=False):
        print(row)
