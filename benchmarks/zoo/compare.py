"""Fit every case of the zoo with physid's methods and with the recipe; one table.

Per case and method:

* **held-out error** ‖τ̂ − τ‖/‖τ‖ on the held-out record, each method predicting from the
  held-out *measured* q on its own rows (physid: ``result.predict(test, measured=True)``, its
  filters and decimation; recipe: its Butterworth, central differences and decimation), against
  one target for all methods at those rows: the simulator's noise-free torque (simulated cases)
  or the measured torque through the recipe's zero-phase Butterworth (real logs);
  the method's own figure (against the measured torque through *its own* filter and
  decimation, what ``physid validate`` prints) and the per-joint errors (rms ratio) are kept too;
* **base-parameter error** (simulated cases): every estimate is expressed in the recipe's base
  parameters (physid's base parameters through its own regressor at random states, an exact
  change of coordinates), the truth mapped through the recipe's base projection, and the mean
  relative error taken over the well-excited base parameters: nonzero truth and relative
  standard error below 10 % in the recipe's fit; the same set for every method;
* physid's ``success`` and message, the wall time of the fit.

physid's default is what ``physid identify`` picks for a URDF model: IDIM-OLS with every option
at its default (``cutoff="auto"``, ``decimate="auto"``, ``stick_threshold="auto"``, physid's FIR
differentiation). With ``cli=True`` the default is also run through the ``physid identify``
command on the same record and its method, success and message compared.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import physid
from physid.estimators import make
from physid.signals.joint_side import joint_side

from . import cases as zoo_cases
from .recipe import Recipe, parameter_error, relative_error, well_excited

DEFAULT_METHOD = "idim-ols"  # `physid identify`'s choice for a model linear in its parameters
METHODS = ("idim-ols", "idim-wls", "idim-iv", "idim-ols:stick_threshold=0")
GOAL = (
    "physid default <= 1.0x recipe held out; well-excited base-parameter error <= recipe's; "
    "no success when > 2x the recipe; no failure when <= the recipe"
)


@dataclass
class Outcome:
    case: str
    method: str  # "recipe" or a physid method
    heldout: float = math.nan  # against the common target
    heldout_own: float = math.nan  # against the measured torque through the method's filter
    per_joint: list = field(default_factory=list)
    param_error: float = math.nan
    n_well: int = 0
    n_base: int = 0
    success: bool | None = None
    message: str = ""
    seconds: float = math.nan
    error: str = ""  # an exception, with its traceback's last lines
    warnings: list = field(default_factory=list)
    cutoff: str = ""
    note: str = ""
    heldout_moving: float = math.nan  # where the case says the robot truly moves (info)

    @property
    def default(self) -> bool:
        return self.method == DEFAULT_METHOD


def parse_method(spec: str):
    """``"idim-ols:stick_threshold=0,decimate=10"`` -> ("idim-ols", {...}) (numbers parsed)."""
    name, _, rest = spec.partition(":")
    settings = {}
    for item in filter(None, (x.strip() for x in rest.split(","))):
        key, _, value = item.partition("=")
        try:
            settings[key.strip()] = float(value) if "." in value or "e" in value else int(value)
        except ValueError:
            settings[key.strip()] = value.strip()
    return name, settings


def _first_line(text: str) -> str:
    return (text or "").strip().splitlines()[0] if (text or "").strip() else ""


def _target_at(case, recipe_cut, recipe, t_rows):
    """The common target at the rows' times."""
    ref = case.test_tau_true
    if ref is None:
        ref = recipe.filtered_torque(case.test, recipe_cut)
    return np.column_stack([np.interp(t_rows, case.test.t, ref[:, j]) for j in range(ref.shape[1])])


def _moving_error(case, t_rows, pred, target) -> float:
    """‖τ̂−τ‖/‖τ‖ on the rows at samples where ``case.info["test_moving"]`` is true (the
    held-out samples where the robot truly moves: at rest the holding friction is unknown)."""
    moving = case.info.get("test_moving")
    if moving is None:
        return math.nan
    k = np.clip(np.round((t_rows - case.test.t[0]) / case.test.dt).astype(int), 0, moving.size - 1)
    return relative_error(pred[moving[k]], target[moving[k]])[0]


def _physid_in_recipe_base(model, result, recipe):
    """physid's base estimate as the recipe's base parameters (and the mapping's residual)."""
    names = list(model.regressor_names)
    idx = [names.index(c) for c in result.columns]
    beta = np.array([result.parameters[n] for n in result.names])

    def torque(q, qd, qdd):
        return np.asarray(model.regressor(q, qd, qdd))[:, :, idx] @ beta

    return recipe.from_torque_model(torque)


def _recipe_outcome(case, recipe, cut, label):
    """Fit the recipe, predict the held-out record; the outcome and the fit."""
    t0 = time.perf_counter()
    rfit = recipe.fit(case.train, cut)
    secs = time.perf_counter() - t0
    t_rows, tau_hat, tau_f = recipe.predict(rfit, case.test)
    target = _target_at(case, cut, recipe, t_rows)
    err, per = relative_error(tau_hat, target)
    own, _ = relative_error(tau_hat, tau_f)
    note = f"{rfit.n_rows} rows, decimate {rfit.decimate}, cond {rfit.condition_number:.3g}"
    o = Outcome(
        case.key,
        label,
        err,
        own,
        per.tolist(),
        seconds=secs,
        cutoff=f"{cut:.3g} Hz",
        n_base=recipe.n_base,
        note=note,
    )
    o.heldout_moving = _moving_error(case, t_rows, tau_hat, target)
    return o, rfit


def run_case(case, methods=METHODS, *, cli=False, log=None) -> tuple[list[Outcome], dict]:
    """All outcomes of one case, and facts about it (recipe cut-off, well-excited count ...)."""
    log = log or (lambda *_: None)
    facts = {"title": case.title, "note": case.note, "skipped": case.skipped}
    if case.skipped:
        return [], facts
    recipe = Recipe(case.urdf, armature=case.armature, offset=case.offset)
    cut = 5.0 * case.bandwidth_hz
    facts.update(
        recipe_cutoff_hz=cut,
        n_train=case.train.n_samples,
        fs=1.0 / case.train.dt,
        duration=(case.train.duration, case.test.duration),
        n_base_recipe=recipe.n_base,
    )
    out = []

    # -- the recipe (the baseline), then its parallel-filtered variant (for information)
    rec_out, rfit = _recipe_outcome(case, recipe, cut, "recipe")
    truth_base = well = None
    if case.truth is not None:
        truth_base = recipe.truth(case.truth)
        well = well_excited(rfit, truth_base)
        facts["well_excited"] = [recipe.base_names[k] for k in np.flatnonzero(well)]
        rec_out.param_error = parameter_error(rfit.beta, truth_base, well)
        rec_out.n_well = int(well.sum())
        facts["frictionless"] = not np.any(case.truth.coulomb) and not np.any(case.truth.viscous)
        if case.train_clean is not None:  # the self-check: noise-free data, same recipe
            cfit = recipe.fit(case.train_clean, cut)
            ct, ch, _ = recipe.predict(cfit, case.test)
            facts["recipe_noise_free_param_error"] = parameter_error(cfit.beta, truth_base, well)
            facts["recipe_noise_free_heldout"] = relative_error(
                ch, _target_at(case, cut, recipe, ct)
            )[0]
    out.append(rec_out)
    log(f"  recipe: held-out {rec_out.heldout:.4g}, {rec_out.seconds:.1f} s")
    pf = Recipe(case.urdf, armature=case.armature, offset=case.offset, parallel=True)
    pf_out, pf_fit = _recipe_outcome(case, pf, cut, "recipe+pf")
    if truth_base is not None:
        pf_out.param_error = parameter_error(pf_fit.beta, truth_base, well)
        pf_out.n_well = int(well.sum())
    out.append(pf_out)
    log(f"  recipe+pf: held-out {pf_out.heldout:.4g}, {pf_out.seconds:.1f} s")

    # -- physid
    model = physid.load_model(case.physid_model)
    # a log of motor-side channels (qm, im) goes through the model's transmission, as
    # `physid identify` does it; the recipe reads the joint-side record
    train = joint_side(model, case.physid_train) if case.physid_train is not None else case.train
    test = joint_side(model, case.physid_test) if case.physid_test is not None else case.test
    for method in methods:
        o = Outcome(case.key, method)
        if method == "idim-iv" and "r1" not in train:
            o.error = "n/a: the log has no reference r1..rn and no PD gains (IV simulates the loop)"
            out.append(o)
            continue
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                name, settings = parse_method(method)
                res = make(name, model, **settings).fit(train).result_
            o.seconds = time.perf_counter() - t0
            o.warnings = sorted({_first_line(str(w.message)) for w in caught})
            o.success, o.message = bool(res.success), _first_line(res.message)
            o.cutoff = f"{res.cutoff / (2 * np.pi * case.train.dt):.3g} Hz, decimate {res.decimate}"
            pred = res.predict(test, measured=True)
            nj = recipe.nj
            P = np.asarray(pred.select([f"tau{j + 1}" for j in range(nj)]))
            M = np.asarray(pred.select([f"tau{j + 1}_measured" for j in range(nj)]))
            target = _target_at(case, cut, recipe, pred.t)
            o.heldout, per = relative_error(P, target)
            o.heldout_moving = _moving_error(case, pred.t, P, target)
            o.per_joint = per.tolist()
            o.heldout_own = relative_error(P, M)[0]
            if truth_base is not None:
                beta, resid = _physid_in_recipe_base(model, res, recipe)
                o.param_error = parameter_error(beta, truth_base, well)
                o.n_well = int(well.sum())
                if resid > 1e-6:
                    o.note = f"physid's base -> recipe's base residual {resid:.1e}"
            o.n_base = len(res.names)
        except Exception as exc:  # a finding: the table shows it, the run goes on
            o.seconds = time.perf_counter() - t0
            o.error = f"{type(exc).__name__}: {_first_line(str(exc))}"
            tb = traceback.format_exc().strip().splitlines()
            shown = facts.setdefault("tracebacks", {})
            if o.error not in {e for e, _ in shown.values()}:
                shown[method] = (o.error, "\n".join(tb[-6:]))
        out.append(o)
        log(
            f"  {method}: held-out {o.heldout:.4g}, success {o.success}, {o.seconds:.1f} s"
            + (f", {o.error}" if o.error else "")
        )
        if cli and method == DEFAULT_METHOD:
            facts["cli"] = _cli_check(case, o)
    return out, facts


def _cli_check(case, outcome) -> str:
    """Run ``physid identify`` (default method) on the record; say whether it agrees."""
    with tempfile.TemporaryDirectory(prefix="physid-zoo-") as tmp:
        path = Path(tmp) / f"{case.key}_train.csv"
        (case.physid_train if case.physid_train is not None else case.train).save(str(path))
        env = dict(os.environ)
        src = str(zoo_cases.ROOT / "src")
        env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        p = subprocess.run(
            [
                sys.executable,
                "-m",
                "physid",
                "identify",
                str(path),
                "--model",
                case.physid_model,
                "--json",
            ],
            capture_output=True,
            text=True,
            env=env,
            timeout=600,
        )
    try:
        d = json.loads(p.stdout)
    except json.JSONDecodeError:
        err = next(
            (ln for ln in p.stderr.splitlines() if ln.startswith("physid: error")),
            _first_line(p.stderr[-400:]),
        )
        same = bool(outcome.error) and outcome.error.split(": ", 1)[-1][:60] in err
        return (
            f"physid identify exited {p.returncode} ({'the same error' if same else 'DIFFERENT'}"
            f" as the Python call): {_short(err, 160)}"
        )
    same = (
        d.get("method") == DEFAULT_METHOD
        and bool(d.get("success")) == outcome.success
        and _first_line(d.get("message", "")) == outcome.message
    )
    return (
        f"physid identify: method {d.get('method')}, success {d.get('success')}, exit "
        f"{p.returncode}; {'same' if same else 'DIFFERENT'} as the Python call"
    )


def verdict(o: Outcome, recipe_err: float) -> str:
    """'ok', 'false success' (success with > 2x the recipe's error) or 'false failure'."""
    if o.error or o.success is None or not math.isfinite(recipe_err):
        return "-"
    if o.success and o.heldout > 2 * recipe_err:
        return "false success"
    if not o.success and o.heldout <= recipe_err:
        return "false failure"
    return "ok"


def bench_rows(outcomes, facts) -> list[dict]:
    """Rows for benchmarks/run.py: the default against the recipe (goal), the other methods."""
    rows = []
    rec = next((o for o in outcomes if o.method == "recipe"), None)
    if rec is None:
        rows.append(
            {
                "benchmark": "zoo",
                "case": f"{facts['title']}: skipped ({facts['skipped']})",
                "value": None,
                "unit": "",
                "goal": GOAL,
                "met": None,
            }
        )
        return rows
    for o in outcomes:
        if o.method == "recipe":
            continue
        if o.method.startswith("recipe"):
            rows.append(
                {
                    "benchmark": "zoo",
                    "case": f"({o.case}) {facts['title']}: held-out τ error, {o.method} "
                    "(parallel-filtered regressor, for information)",
                    "value": o.heldout,
                    "unit": "",
                    "baseline": "recipe",
                    "baseline_value": rec.heldout,
                    "ratio": rec.heldout / o.heldout if o.heldout > 0 else math.nan,
                    "param_error": o.param_error,
                }
            )
            continue
        ratio = rec.heldout / o.heldout if o.heldout > 0 else math.nan
        v = verdict(o, rec.heldout)
        row = {
            "benchmark": "zoo",
            "case": f"({o.case}) {facts['title']}: held-out τ error, physid {o.method}"
            + (" (default)" if o.default else ""),
            "value": o.heldout,
            "unit": "",
            "baseline": "recipe (Butterworth 5x bandwidth, central diff, OLS)",
            "baseline_value": rec.heldout,
            "ratio": ratio,
            "goal": GOAL if o.default else None,
            "met": (
                bool(
                    o.heldout <= rec.heldout
                    and v == "ok"
                    and o.success
                    and not (o.param_error > rec.param_error)  # NaN (no truth): not judged
                )
                if o.default and not o.error
                else (False if o.default else None)
            ),
            "physid_success": o.success,
            "physid_message": o.error or o.message,
            "verdict": v,
            "param_error": o.param_error,
            "recipe_param_error": rec.param_error,
            "n_well_excited": o.n_well,
            "seconds": o.seconds,
            "recipe_seconds": rec.seconds,
            "filter": o.cutoff,
            "heldout_moving": o.heldout_moving,
        }
        rows.append(row)
    if "recipe_noise_free_param_error" in facts and facts.get("frictionless"):
        pe = facts["recipe_noise_free_param_error"]
        he = facts["recipe_noise_free_heldout"]
        rows.append(
            {
                "benchmark": "zoo",
                "case": f"({rec.case}) self-check: recipe on the noise-free record, mean |base "
                f"parameter error| ({rec.n_well} well-excited); held-out {he:.2g}",
                "value": pe,
                "unit": "",
                "goal": "< 0.01 (and held-out < 0.005)",
                "met": bool(pe < 0.01 and he < 0.005),
            }
        )
    return rows


# ------------------------------------------------------------------------------- tables
def _f(x, digits=3):
    if x is None:
        return "-"
    if isinstance(x, float):
        return "-" if not math.isfinite(x) else f"{x:.{digits}g}"
    return str(x)


def _short(msg: str, n=320) -> str:
    """The message without its parenthesised details, '|' escaped, at most n characters."""
    msg = re.sub(r"\s*\([^()]*\)", "", msg).replace("|", "/")
    for prefix in ("IDIM-OLS on ", "IDIM-WLS on ", "IDIM-IV on "):
        if msg.startswith(prefix):
            msg = msg[len(prefix) :]
    return msg if len(msg) <= n else msg[: n - 1] + "…"


def markdown(all_outcomes, all_facts) -> str:
    """The full table, one row per case and method, then the notes per case."""
    head = (
        "| case | method | held-out ‖τ̂−τ‖/‖τ‖ | own-filter | per joint | base-param err "
        "(n well) | success | verdict | fit s | filter | message |"
    )
    lines = [head, "|" + "---|" * 11]
    for outcomes in all_outcomes:
        if not outcomes:
            continue
        rec = outcomes[0]
        for o in outcomes:
            label = o.method + (" (default)" if o.default else "")
            msg = o.error or o.message
            lines.append(
                f"| {o.case} | {label} | {_f(o.heldout)} | {_f(o.heldout_own)} | "
                + (" ".join(_f(x, 2) for x in o.per_joint) or "-")
                + f" | {_f(o.param_error)} ({o.n_well}) | "
                + ("-" if o.success is None else ("yes" if o.success else "no"))
                + f" | {'-' if o.method.startswith('recipe') else verdict(o, rec.heldout)} | "
                f"{_f(o.seconds, 2)} | {o.cutoff} | {_short(msg) if msg else (o.note or '')} |"
            )
    lines.append("")
    for outcomes, facts in zip(all_outcomes, all_facts, strict=True):
        key = outcomes[0].case if outcomes else "?"
        parts = [f"- **{facts['title']}**"]
        if facts.get("skipped"):
            parts.append(f"skipped: {facts['skipped']}")
        else:
            parts.append(
                f"{facts['n_train']} samples at {facts['fs']:.4g} Hz, "
                f"{facts['duration'][0]:.3g} s / held out {facts['duration'][1]:.3g} s; "
                f"recipe cut-off {facts['recipe_cutoff_hz']:.3g} Hz, "
                f"{facts['n_base_recipe']} base parameters"
            )
            if "recipe_noise_free_param_error" in facts and facts.get("frictionless"):
                parts.append(
                    f"recipe on the noise-free record: base-parameter error "
                    f"{facts['recipe_noise_free_param_error']:.2g}, held-out "
                    f"{facts['recipe_noise_free_heldout']:.2g}"
                )
            if facts.get("note"):
                parts.append(facts["note"])
            moving = [(o.method, o.heldout_moving) for o in outcomes]
            if any(math.isfinite(e) for _, e in moving):
                parts.append(
                    "held-out error where the robot truly moves: "
                    + ", ".join(f"{m} {_f(e)}" for m, e in moving if math.isfinite(e))
                )
            if facts.get("cli"):
                parts.append(facts["cli"])
            for o in outcomes:
                if o.warnings:
                    parts.append(
                        f"{o.method} warned: " + " / ".join(_short(w, 200) for w in o.warnings)
                    )
            for m, (_, tb) in facts.get("tracebacks", {}).items():
                parts.append(f"{m} raised:\n\n```\n{tb}\n```\n")
        lines.append(f"{'; '.join(parts)} [{key}]")
    return "\n".join(lines)


def run(quick=False, keys=None, methods=None, cli=None, log=None):
    """Build the cases, fit them, return (outcomes per case, facts per case)."""
    log = log or (lambda *_: None)
    methods = methods or (
        ("idim-ols", "idim-wls", "idim-ols:stick_threshold=0") if quick else METHODS
    )
    cli = (not quick) if cli is None else cli
    all_out, all_facts = [], []
    keys = keys or list(zoo_cases.BUILDERS)
    for k in ["aq"] if quick else keys:
        t0 = time.perf_counter()
        case = zoo_cases.case_a(quick=True) if k == "aq" else zoo_cases.BUILDERS[k]()
        log(f"[zoo] case ({case.key}) {case.title}: built in {time.perf_counter() - t0:.1f} s")
        out, facts = run_case(case, methods, cli=cli, log=log)
        all_out.append(out)
        all_facts.append(facts)
    return all_out, all_facts
