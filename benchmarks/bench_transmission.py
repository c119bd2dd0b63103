"""A coupled wrist (motor 6 turns with q5 + q6): physid against the robotics recipe with the
coupling terms, on the same motor-side records.

The records are tests/_wrist_logs.py's (the test of the transmission tables uses the same ones):
physid's 6-DOF ``arm6`` simulated by pinocchio plus six rotors written from their definition,
θm = K q with K = diag(100, 100, 80, 60, 60, 50) and K[6, 5] = 50 (1-based), τ = Kᵀ τm; each
rotor's inertia Im, viscous Fvm and Coulomb Fcm act on its own angle. 200 Hz, 20 s of a 4-harmonic
Fourier motion (highest harmonic 0.4 Hz), white noise of 2 mN·m on the motor torques; the
identification record has seed 1, the held-out one seed 2.

* physid, its defaults: ``physid identify ident.csv --model coupled.toml --method idim-ols --save
  fit.json``, then ``physid validate fit.json held.csv --json`` (held-out ‖τ̂ − τ‖/‖τ‖ on the
  signals filtered as the fit filtered them).
* the recipe (benchmarks/zoo/recipe.py: 4th-order Butterworth filtfilt at 5× the highest
  harmonic, np.gradient, decimation, OLS on pinocchio's base regressor), fed the joint-side
  signals a practitioner computes by hand (q = K⁻¹ θm, τ = Kᵀ τm), with the motor columns
  derived here: motor k's terms act on θm_k = K[k]·q, so their joint torque is
  K[k]ᵀ (Im_k θ̈m_k + Fvm_k θ̇m_k + Fcm_k sign θ̇m_k), three columns per motor, K[k]ᵀ θ̈m_k,
  K[k]ᵀ θ̇m_k and K[k]ᵀ sign θ̇m_k (for a diagonal row, the joint's armature and friction
  scaled by N², N², |N|). Held-out error on its own filtered rows (the same convention as
  ``validate``).
* the same recipe with Gautier's parallel filter (the regressor's columns through the
  Butterworth before the decimation), for information;
* the recipe without the coupling terms, for reference: the same columns with K's diagonal only
  (per-joint armature and friction), what a per-joint recipe can say about motor 6.

Rows, each the median over 5 draws of the torque noise (the first draw is the test's records):
physid's held-out error against the coupled recipe's (overall and on the two wrist joints; goal
physid ≤ recipe); the same with every estimate applied to the held-out trajectory's exact states
and compared with its noise-free torque (one target for all, free of either filter: each
``validate``-convention error is taken on the method's own filtered torque, and physid's filter
passes more of the noise than the recipe's 2 Hz, which knows the trajectory's bandwidth); the
parallel-filtered and the per-joint recipes on both measures, for information; and the
self-check: the recipe's full and base regressors times the true parameters against the
simulator's torque on noise-free states (goal ≤ 1e-12 relative; a failure raises). ``--quick``:
one draw of 10 s records, no goal judged but the self-check.

    python benchmarks/run.py --only transmission [--quick]
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
GOAL = "physid ≤ recipe"


def _wrist():
    sys.path.insert(0, str(HERE.parent / "tests"))
    try:
        import _wrist_logs
    finally:
        sys.path.pop(0)
    return _wrist_logs


def _coupled_recipe_class():
    from zoo.recipe import Recipe

    class CoupledRecipe(Recipe):
        """The recipe with one inertia, viscous and Coulomb column per motor of θm = K q."""

        def __init__(self, urdf, motor_from_joint, **kw):
            self.motor_from_joint = np.asarray(motor_from_joint, float)
            super().__init__(urdf, armature=True, **kw)  # 3 drive columns per joint: renamed
            motor = {"Ia": "Im", "Fv": "Fvm", "Fc": "Fcm"}

            def rename(n):
                return re.sub(r"^(Ia|Fv|Fc)(\d)", lambda m: motor[m[1]] + m[2], n)

            self.column_names = tuple(rename(n) for n in self.column_names)
            self.base_names = tuple(rename(n) for n in self.base_names)

        def regressor(self, q, qd, qdd):
            Y = super().regressor(q, qd, qdd)
            nj, Km = self.nj, self.motor_from_joint
            c = 10 * nj
            thd, thdd = qd @ Km.T, qdd @ Km.T  # θ̇m = K q̇, θ̈m = K q̈
            # column of motor k on joint j: K[k, j] times the motor-side signal of motor k
            Y[:, :, c : c + nj] = thdd[:, None, :] * Km.T
            Y[:, :, c + nj : c + 2 * nj] = thd[:, None, :] * Km.T
            Y[:, :, c + 2 * nj : c + 3 * nj] = np.sign(thd)[:, None, :] * Km.T
            return Y

        def true_base(self, standard, im, fvm, fcm):
            beta = np.concatenate([np.ravel(standard), im, fvm, fcm])
            return beta[self.base] + self.K @ beta[self.dependent]

    return CoupledRecipe


class _Record:
    """The joint-side record a practitioner computes from the motor-side log."""

    def __init__(self, path, K):
        a = np.loadtxt(path, delimiter=",", skiprows=1)
        self.t = a[:, 0]
        q = np.linalg.solve(K, a[:, 1:7].T).T  # q = K⁻¹ θm
        tau = a[:, 7:13] @ K  # τ = Kᵀ τm
        self.channels = {f"q{j + 1}": q[:, j] for j in range(6)}
        self.channels |= {f"tau{j + 1}": tau[:, j] for j in range(6)}

    def select(self, names):
        return np.column_stack([self.channels[n] for n in names])


def _standard_parameters(urdf):
    import pinocchio as pin

    pm = pin.buildModelFromUrdf(str(urdf))
    return np.concatenate([pm.inertias[i].toDynamicParameters() for i in range(1, pm.njoints)])


def _self_check(w, recipe) -> float:
    """max |Y β_true − τ_sim| / max |τ_sim| on noise-free exact states (full and base)."""
    _, q, qd, qdd = w.trajectory(5, T=2.0)
    truth = w.truth_torque(q, qd, qdd)
    std = _standard_parameters(w.URDF)
    beta = np.concatenate([std, w.IM, w.FVM, w.FCM])
    full = np.max(np.abs(recipe.regressor(q, qd, qdd) @ beta - truth))
    base = recipe.base_regressor(q, qd, qdd) @ recipe.true_base(std, w.IM, w.FVM, w.FCM)
    return max(full, float(np.max(np.abs(base - truth)))) / float(np.max(np.abs(truth)))


def _physid(folder: Path, model_path: Path):
    """physid's defaults through its command; (validate's errors, the result file's dict)."""
    from physid.cli import main

    ident, held, fit = (str(folder / n) for n in ("ident.csv", "held.csv", "fit.json"))
    argv = ["identify", ident, "--model", str(model_path), "--method", "idim-ols", "--save", fit]
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        rc = main(argv)
    if rc != 0:
        raise RuntimeError(f"physid identify exited {rc}")
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        rc = main(["validate", fit, held, "--json"])
    if rc != 0:
        raise RuntimeError(f"physid validate exited {rc}")
    return json.loads(out.getvalue())["relative_error"], json.loads(Path(fit).read_text())


def _physid_exact(model_path, result, q, qd, qdd):
    """physid's base estimate applied to exact states."""
    import physid

    model = physid.load_model(model_path)
    names = list(model.regressor_names)
    idx = [names.index(c) for c in result["columns"]]
    beta = np.array([result["parameters"][n] for n in result["names"]])
    return np.asarray(model.regressor(q, qd, qdd))[:, :, idx] @ beta


def _row(case, value, baseline, baseline_value, goal=GOAL):
    return {
        "case": case,
        "value": value,
        "unit": "‖τ̂−τ‖/‖τ‖",
        "baseline": baseline,
        "baseline_value": baseline_value,
        "ratio": baseline_value / value if value > 0 else float("inf"),
        "goal": goal,
        "met": bool(value <= baseline_value) if goal else None,
    }


def _one_draw(w, recipes, T, cut, noise_seed):
    """One pair of records (noise drawn with ``noise_seed``; None: the test's records): every
    method's held-out errors, on its own filtered rows and on the exact states."""
    from zoo.recipe import relative_error

    _, q, qd, qdd = w.trajectory(2, T=T)  # the held-out record's exact states
    tau_true = w.truth_torque(q, qd, qdd)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name, seed in (("ident.csv", 1), ("held.csv", 2)):
            ns = None if noise_seed is None else noise_seed + seed
            w.write_log(folder / name, seed, 0.002, T=T, noise_seed=ns)
        model_path = w.coupled(folder)
        err, result = _physid(folder, model_path)
        exact = relative_error(_physid_exact(model_path, result, q, qd, qdd), tau_true)[0]
        out["physid"] = (err["overall"], err["tau5"], err["tau6"], exact)
        ident, held = (_Record(folder / n, w.K) for n in ("ident.csv", "held.csv"))
        for label, r in recipes.items():
            fit = r.fit(ident, cut)
            _, tau_hat, tau_f = r.predict(fit, held)
            own, per = relative_error(tau_hat, tau_f)
            exact = relative_error(r.base_regressor(q, qd, qdd) @ fit.beta, tau_true)[0]
            out[label] = (own, per[4], per[5], exact)
    return out


def run(quick: bool) -> list[dict]:
    w = _wrist()
    T = 10.0 if quick else 20.0
    draws = [None] if quick else [None, 1000, 2000, 3000, 4000]
    cut = 5.0 * w.HIGHEST_HARMONIC_HZ  # the recipe's cut-off: 5× the highest harmonic [Hz]
    CoupledRecipe = _coupled_recipe_class()
    recipes = {
        "coupled": CoupledRecipe(w.URDF, w.K),
        "parallel": CoupledRecipe(w.URDF, w.K, parallel=True),
        "plain": CoupledRecipe(w.URDF, np.diag(np.diag(w.K))),
    }
    check = _self_check(w, recipes["coupled"])
    if not check <= 1e-12:  # the measuring stick itself is broken: fail loudly
        raise RuntimeError(f"transmission self-check failed: {check:.3g}")
    runs = [_one_draw(w, recipes, T, cut, d) for d in draws]
    med = {k: np.median([r[k] for r in runs], axis=0) for k in runs[0]}
    p = med["physid"]
    names = {
        "coupled": "recipe + coupling columns",
        "parallel": "recipe + coupling columns, parallel filter",
        "plain": "recipe, per-joint columns only",
    }
    tag = f" (median of {len(draws)} noise draws)" if len(draws) > 1 else ""
    c = med["coupled"]
    rows = [
        _row(f"held-out, overall (validate){tag}", p[0], names["coupled"], c[0]),
        _row(f"held-out, tau5 (validate){tag}", p[1], names["coupled"], c[1]),
        _row(f"held-out, tau6 (validate){tag}", p[2], names["coupled"], c[2]),
        _row(f"exact states, overall{tag}", p[3], names["coupled"], c[3]),
    ]
    for label in ("parallel", "plain"):  # for information
        b = med[label]
        rows.append(_row(f"held-out, overall (validate){tag}", p[0], names[label], b[0], None))
        rows.append(_row(f"exact states, overall{tag}", p[3], names[label], b[3], None))
    rows.append(
        {
            "case": "self-check: recipe's columns × truth vs the simulator (noise-free)",
            "value": check,
            "unit": "max |Δτ| / max |τ|",
            "goal": "≤ 1e-12",
            "met": True,
        }
    )
    if quick:  # one short draw: no goal judged but the self-check
        for r in rows[:-1]:
            r["met"] = None
    return rows


if __name__ == "__main__":
    print(json.dumps(run("--quick" in sys.argv), indent=1, default=str))
