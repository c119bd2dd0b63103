"""Model derivation and evaluation speed, against pinocchio measured in the same run.

Rows:
* cold derivation + code generation of the paper's 4-DOF arm (goal < 3 s) and of a 6-DOF DH arm
  with point masses and rotor inertias (goal < 60 s; full mode only), each in a fresh process
  with an empty cache, timing ``load_model`` itself (sympy is imported lazily inside it, so that
  import is included);
* warm load from the on-disk cache in a fresh process (goal < 0.2 s);
* inverse dynamics on 1e5 samples (vectorised) against pinocchio's ``rnea`` looped in Python
  over the samples — what a pinocchio user does, since pinocchio has no batched Python API;
* forward dynamics: batched ``forward_dynamics`` against ``aba`` looped; the single-state
  ``make_rhs`` against one ``aba`` call; the fused closed-loop ``simulate.pd_rhs`` against the same
  PD law written with numpy around ``aba`` (what a solve_ivp right-hand side would do).

Rigid-body rows (a 7-DOF Panda-like URDF, tests/data/arm7.urdf, with a sidecar adding armature,
viscous and Coulomb friction: 91 regressor columns):
* cold load (empty cache: parse + build + compile the generic C kernel on first use) and warm
  load (fresh process, kernel cached), each including the first inverse-dynamics call;
* inverse dynamics and the regressor at 1e5 samples against pinocchio's ``rnea`` and
  ``computeJointTorqueRegressor`` looped in Python (20 000 samples, extrapolated);
* peak memory (tracemalloc) of the regressor against the size of one float64 copy of it.

Ratios are ours-over-theirs speed (> 1: we are faster). Run: python benchmarks/run.py --only models
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time
import timeit
from pathlib import Path

import numpy as np

SIX_DOF = """
name = "six_dof_bench"
gravity = [0, 0, -9.81]
[parameters]
m1 = { value = 10.0, unit = "kg" }
m2 = { value = 8.0, unit = "kg" }
m3 = { value = 6.0, unit = "kg" }
m4 = { value = 3.0, unit = "kg" }
m5 = { value = 2.0, unit = "kg" }
m6 = { value = 1.0, unit = "kg" }
a2 = { value = 0.43, unit = "m" }
a3 = { value = 0.02, unit = "m" }
d1 = { value = 0.67, unit = "m" }
d3 = { value = 0.15, unit = "m" }
d4 = { value = 0.43, unit = "m" }
d6 = { value = 0.06, unit = "m" }
[[joints]]
dh = { a = 0, alpha = "pi/2", d = "d1" }
mass = "m1"
rotor_inertia = 0.02
[[joints]]
dh = { a = "a2", alpha = 0 }
mass = "m2"
rotor_inertia = 0.02
[[joints]]
dh = { a = "a3", alpha = "-pi/2", d = "d3" }
mass = "m3"
rotor_inertia = 0.02
[[joints]]
dh = { a = 0, alpha = "pi/2", d = "d4" }
mass = "m4"
rotor_inertia = 0.02
[[joints]]
dh = { a = 0, alpha = "-pi/2" }
mass = "m5"
rotor_inertia = 0.02
[[joints]]
dh = { a = 0, alpha = 0, d = "d6" }
mass = "m6"
rotor_inertia = 0.02
"""


def _timed_load(target: str, cache_dir: str) -> dict:
    """Load a model in a fresh interpreter; return the load time [s] and whether it was cached."""
    code = textwrap.dedent(f"""
        import json, time
        import physid.models
        t = time.perf_counter()
        m = physid.models.load_model({target!r})
        print(json.dumps({{"seconds": time.perf_counter() - t, "cached": m.loaded_from_cache}}))
    """)
    env = dict(os.environ, PHYSID_CACHE_DIR=cache_dir)
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _best(fn, number: int, repeat: int = 5) -> float:
    """Best time per call [s] over ``repeat`` runs of ``number`` calls."""
    return min(timeit.repeat(fn, number=number, repeat=repeat)) / number


ARM7 = Path(__file__).resolve().parent.parent / "tests" / "data" / "arm7.urdf"
SIDECAR = """
name = "arm7_friction"
extends = "arm7.urdf"
""" + "".join(
    f"[joints.joint{j}]\narmature = {0.3 / j:.4g}\nviscous = {1.0 / j:.4g}\ncoulomb = {0.8 / j:.4g}\n"
    for j in range(1, 8)
)


def _timed_rigid_load(target: str, cache_dir: str) -> dict:
    code = textwrap.dedent(f"""
        import json, time
        import numpy as np
        import physid.models
        t = time.perf_counter()
        m = physid.models.load_model({target!r})
        t_load = time.perf_counter() - t
        m.inverse_dynamics(np.zeros((1, m.n_joints)), np.zeros((1, m.n_joints)),
                           np.zeros((1, m.n_joints)))
        print(json.dumps({{"seconds": time.perf_counter() - t, "load": t_load,
                           "n_columns": len(m.regressor_names)}}))
    """)
    env = dict(os.environ, PHYSID_CACHE_DIR=cache_dir)
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _rigid_rows(quick: bool) -> list[dict]:
    import shutil
    import tracemalloc

    import pinocchio as pin

    from physid.models import load_model

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copy(ARM7, Path(tmp) / "arm7.urdf")
        side = Path(tmp) / "arm7.toml"
        side.write_text(SIDECAR, encoding="utf-8")
        cache = str(Path(tmp) / "cache")
        cold = _timed_rigid_load(str(side), cache)
        warm = _timed_rigid_load(str(side), cache)
        model = load_model(side)
    cols = cold["n_columns"]
    rows.append(
        dict(
            case=f"cold load 7-DOF rigid (full inertia + armature + friction, {cols} columns; "
            "incl. C kernel build and first call)",
            value=cold["seconds"],
            unit="s",
            goal="< 30 s",
            met=cold["seconds"] < 30.0,
        )
    )
    rows.append(
        dict(
            case="warm load 7-DOF rigid (fresh process, kernel cached, incl. first call)",
            value=warm["seconds"],
            unit="s",
            baseline="cold load",
            baseline_value=cold["seconds"],
            ratio=cold["seconds"] / warm["seconds"],
            goal="< 0.2 s",
            met=warm["seconds"] < 0.2,
        )
    )
    pm = pin.buildModelFromUrdf(str(ARM7))
    pdata = pm.createData()
    n = 20_000 if quick else 100_000
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.normal(size=(3, n, 7))
    n_pin = min(n, 20_000)
    t_ours = _best(lambda: model.inverse_dynamics(q, qd, qdd), number=1, repeat=3)
    rnea = pin.rnea

    def pin_id():
        for i in range(n_pin):
            rnea(pm, pdata, q[i], qd[i], qdd[i])

    t_pin = _best(pin_id, number=1, repeat=3) * n / n_pin
    rows.append(
        dict(
            case=f"inverse dynamics 7-DOF rigid, {n:.0e} samples",
            value=n / t_ours,
            unit="samples/s",
            baseline="pinocchio rnea (python loop)",
            baseline_value=n / t_pin,
            ratio=t_pin / t_ours,
            goal="at least as fast as pinocchio",
            met=t_pin >= t_ours,
        )
    )
    out = np.empty((n, 7, cols))
    t_reg = _best(lambda: model.regressor(q, qd, qdd, out=out), number=1, repeat=3)
    reg = pin.computeJointTorqueRegressor

    def pin_reg():
        for i in range(n_pin):
            reg(pm, pdata, q[i], qd[i], qdd[i])

    t_preg = _best(pin_reg, number=1, repeat=3) * n / n_pin
    rows.append(
        dict(
            case=f"regressor 7-DOF rigid ({cols} columns), {n:.0e} samples",
            value=n / t_reg,
            unit="samples/s",
            baseline="pinocchio computeJointTorqueRegressor (python loop, 70 columns)",
            baseline_value=n / t_preg,
            ratio=t_preg / t_reg,
            goal="at least as fast as pinocchio",
            met=t_preg >= t_reg,
        )
    )
    out = None
    tracemalloc.start()
    Y = model.regressor(q, qd, qdd)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rows.append(
        dict(
            case=f"peak memory of the regressor, {n:.0e} x 7 x {cols} (tracemalloc)",
            value=peak / 1e6,
            unit="MB",
            baseline="one float64 copy of Y",
            baseline_value=Y.nbytes / 1e6,
            ratio=Y.nbytes / peak,
            goal="<= one copy (+ 5 %)",
            met=peak <= 1.05 * Y.nbytes,
        )
    )
    del Y
    start = time.perf_counter()
    bp = model.base_parameters()
    rows.append(
        dict(
            case=f"base parameters 7-DOF rigid ({bp.n_base} of {cols})",
            value=time.perf_counter() - start,
            unit="s",
            goal="informational",
            met=None,
        )
    )
    return rows


def run(quick: bool = False) -> list[dict]:
    return _rigid_rows(quick) + _symbolic_rows(quick)


def _symbolic_rows(quick: bool = False) -> list[dict]:
    import pinocchio as pin

    from physid.models import load_model
    from physid.models.peers import pinocchio_model
    from physid.simulate.pd import pd_rhs

    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        cache = str(Path(tmp) / "cache")
        cold = _timed_load("manipulator", cache)
        warm = _timed_load("manipulator", cache)
        rows.append(
            dict(
                case="cold derivation + codegen, 4-DOF arm",
                value=cold["seconds"],
                unit="s",
                goal="< 3 s",
                met=cold["seconds"] < 3.0 and not cold["cached"],
            )
        )
        rows.append(
            dict(
                case="warm (cached) load, 4-DOF arm",
                value=warm["seconds"],
                unit="s",
                baseline="cold load",
                baseline_value=cold["seconds"],
                ratio=cold["seconds"] / warm["seconds"],
                goal="< 0.2 s",
                met=warm["seconds"] < 0.2 and warm["cached"],
            )
        )
        if not quick:
            six = Path(tmp) / "six.toml"
            six.write_text(SIX_DOF, encoding="utf-8")
            cold6 = _timed_load(str(six), cache)
            rows.append(
                dict(
                    case="cold derivation + codegen, 6-DOF DH arm",
                    value=cold6["seconds"],
                    unit="s",
                    goal="< 60 s",
                    met=cold6["seconds"] < 60.0,
                )
            )
            model6 = None
            os.environ.setdefault("PHYSID_CACHE_DIR", cache)
            model6 = load_model(six)

    model = load_model("manipulator")
    models = [("4-DOF", model)] + ([("6-DOF", model6)] if not quick else [])
    rng = np.random.default_rng(0)
    n = 10_000 if quick else 100_000
    for label, m in models:
        nj = m.n_joints
        pm, pdata = pinocchio_model(m)
        q = rng.uniform(-np.pi, np.pi, (n, nj))
        qd = rng.normal(size=(n, nj))
        qdd = rng.normal(size=(n, nj))
        tau = m.inverse_dynamics(q, qd, qdd)

        # inverse dynamics: vectorised vs rnea looped over samples
        t_ours = _best(
            lambda m=m, q=q, qd=qd, qdd=qdd: m.inverse_dynamics(q, qd, qdd), number=1, repeat=3
        )
        n_pin = min(n, 20_000)
        rnea = pin.rnea

        def pin_id(pm=pm, pdata=pdata, q=q, qd=qd, qdd=qdd, n_pin=n_pin, rnea=rnea):
            for i in range(n_pin):
                rnea(pm, pdata, q[i], qd[i], qdd[i])

        t_pin = _best(pin_id, number=1, repeat=3) * n / n_pin
        rows.append(
            dict(
                case=f"inverse dynamics, {n:.0e} samples, {label}",
                value=n / t_ours,
                unit="samples/s",
                baseline="pinocchio rnea (python loop)",
                baseline_value=n / t_pin,
                ratio=t_pin / t_ours,
                goal="faster than pinocchio",
                met=t_pin > t_ours,
            )
        )

        # batched forward dynamics vs aba looped
        t_fd = _best(
            lambda m=m, q=q, qd=qd, tau=tau: m.forward_dynamics(q, qd, tau), number=1, repeat=3
        )
        aba = pin.aba

        def pin_fd(pm=pm, pdata=pdata, q=q, qd=qd, tau=tau, n_pin=n_pin, aba=aba):
            for i in range(n_pin):
                aba(pm, pdata, q[i], qd[i], tau[i])

        t_pfd = _best(pin_fd, number=1, repeat=3) * n / n_pin
        rows.append(
            dict(
                case=f"forward dynamics batched, {n:.0e} samples, {label}",
                value=n / t_fd,
                unit="evals/s",
                baseline="pinocchio aba (python loop)",
                baseline_value=n / t_pfd,
                ratio=t_pfd / t_fd,
                goal="faster than pinocchio",
                met=t_pfd > t_fd,
            )
        )

        # single state: make_rhs vs one aba call (numpy arrays in, array out)
        rhs = m.make_rhs()
        q0, qd0, tau0 = q[0].copy(), qd[0].copy(), tau[0].copy()
        calls = 2_000 if quick else 20_000
        t_rhs = _best(lambda rhs=rhs, q0=q0, qd0=qd0, tau0=tau0: rhs(q0, qd0, tau0), number=calls)
        t_aba = _best(
            lambda pm=pm, pdata=pdata, q0=q0, qd0=qd0, tau0=tau0, aba=aba: aba(
                pm, pdata, q0, qd0, tau0
            ),
            number=calls,
        )
        rows.append(
            dict(
                case=f"forward dynamics single state (make_rhs), {label}",
                value=1 / t_rhs,
                unit="evals/s",
                baseline="pinocchio aba, one call",
                baseline_value=1 / t_aba,
                ratio=t_aba / t_rhs,
                goal="informational (pure Python vs C++)",
                met=None,
            )
        )

        # fused closed-loop PD right-hand side, as solve_ivp calls it
        kp = np.linspace(500.0, 4000.0, nj)
        kd = np.linspace(2.0, 150.0, nj)
        r_vec = np.full(nj, 0.5)

        def reference(t, r_vec=r_vec):
            return r_vec

        fused = pd_rhs(m, kp=kp, kd=kd, reference=reference)

        def pin_pd(t, y, pm=pm, pdata=pdata, nj=nj, kp=kp, kd=kd, aba=aba):
            qy, qdy = y[:nj], y[nj:]
            u = kp * (reference(t) - qy) - kd * qdy  # τ = Kp (r − q) − Kd q̇
            return np.concatenate((qdy, aba(pm, pdata, qy, qdy, u)))

        y0 = np.r_[q0, qd0]
        assert np.allclose(fused(0.3, y0), pin_pd(0.3, y0), rtol=1e-8, atol=1e-6)
        t_f = _best(lambda fused=fused, y0=y0: fused(0.3, y0), number=calls)
        t_p = _best(lambda pin_pd=pin_pd, y0=y0: pin_pd(0.3, y0), number=calls)
        rows.append(
            dict(
                case=f"closed-loop PD rhs f(t, y) (simulate.pd_rhs), {label}",
                value=1 / t_f,
                unit="evals/s",
                baseline="numpy PD + pinocchio aba",
                baseline_value=1 / t_p,
                ratio=t_p / t_f,
                goal="faster than pinocchio",
                met=t_p > t_f,
            )
        )

    # regressor derivation (lazy, on first use), in-process with a fresh cache
    with tempfile.TemporaryDirectory() as tmp:
        old = os.environ.get("PHYSID_CACHE_DIR")
        os.environ["PHYSID_CACHE_DIR"] = tmp
        try:
            m = load_model("manipulator")
            start = time.perf_counter()
            bp = m.base_parameters()
            t_reg = time.perf_counter() - start
        finally:
            if old is None:
                os.environ.pop("PHYSID_CACHE_DIR", None)
            else:
                os.environ["PHYSID_CACHE_DIR"] = old
    rows.append(
        dict(
            case=f"regressor derivation + base parameters, 4-DOF ({bp.n_base} base)",
            value=t_reg,
            unit="s",
            goal="informational",
            met=None,
        )
    )
    return rows


if __name__ == "__main__":
    for row in run(quick="--quick" in sys.argv):
        print(row)
