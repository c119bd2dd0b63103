"""Wave 3, room arch: the layout moves of issue 12 and the hardening of issue 16, pinned by numbers."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

import physid
import physid.estimators.recursive as recursive
from physid.filters import (
    StreamingStateVariableFilter,
    state_variable_filter,
    svf_transient_samples,
)
from physid.simulate import closed_loop_rhs, pd_rhs


# ------------------------------------------------------------------ state-variable filter move
def test_svf_lives_in_filters_and_recursive_uses_the_same_objects():
    assert state_variable_filter.__module__ == "physid.filters.state_variable"
    assert recursive.state_variable_filter is state_variable_filter
    assert recursive.StreamingStateVariableFilter is StreamingStateVariableFilter
    assert recursive.svf_transient_samples is svf_transient_samples


def test_svf_dc_gain_is_one_and_derivatives_of_a_constant_vanish():
    d = state_variable_filter(np.full(4000, 2.5), 1e-3, 20.0, n_derivatives=2, filter_order=3)
    np.testing.assert_allclose(d[-1], [2.5, 0.0, 0.0], rtol=0, atol=1e-8)


@pytest.mark.parametrize("dt", [1e-3, 5e-4])
def test_svf_of_a_sinusoid_is_the_analytic_steady_state(dt):
    """w^(i) = Im((jω)^i F(jω) e^{jωt}) after the transient, F the analog Butterworth.

    The FOH discretisation is exact for piecewise-linear input; a sine differs from its chords by
    the interpolation error, relative size (ω dt)² / 12 (1.32e-5 at 1 ms, 3.3e-6 at 0.5 ms), so the
    tolerance is 1.1 (ω dt)² / 12 of each derivative's amplitude, and halving dt divides it by 4.
    """
    fc, order, w0 = 20.0, 3, 2 * np.pi * 2.0
    t = np.arange(int(round(2.0 / dt))) * dt
    d = state_variable_filter(np.sin(w0 * t), dt, fc, n_derivatives=2, filter_order=order)
    b, a = signal.butter(order, 2 * np.pi * fc, analog=True)
    H = signal.freqs(b, a, [w0])[1][0]
    keep = t > 0.5  # 500 ms ≫ svf_transient_samples(20, dt, 3) samples
    assert svf_transient_samples(fc, dt, order) * dt < 0.5
    tol = 1.1 * (w0 * dt) ** 2 / 12
    for i in range(3):
        ref = np.imag((1j * w0) ** i * H * np.exp(1j * w0 * t))
        err = np.abs(d[keep, i] - ref[keep]).max() / (w0**i * abs(H))
        assert err < tol, (i, err, tol)
        assert err > 0.5 * (w0 * dt) ** 2 / 12  # the error is the hold's, not something smaller


# ------------------------------------------------------------------ PD law in simulate/
GOLDEN = Path(__file__).parent / "golden"


def test_pd_rhs_is_bit_identical_to_the_wave2_method():
    """The symbolic chain's fused PD right-hand side gives the old method's floats bit for bit."""
    gold = json.loads((GOLDEN / "pd_rhs_wave2.json").read_text())
    arm = physid.load_model("manipulator")
    rng = np.random.default_rng(7)
    kp = np.array([3800.0, 40000.0, 10000.0, 500.0])
    kd = np.array([159.5, 120.0, 50.0, 2.0])
    r = np.array([0.5, 0.4, 0.3, 0.2])
    f = pd_rhs(arm, {"m3": 14.0}, kp=kp, kd=kd, reference=lambda t: r * t)
    g = pd_rhs(arm, {"m3": 14.0}, kp=kp, kd=kd, reference=r)
    ys = rng.normal(size=(3, 8))
    assert [[float(v).hex() for v in f(1.7, y)] for y in ys] == gold["chain_callable"]
    assert [[float(v).hex() for v in g(0.0, y)] for y in ys] == gold["chain_const"]
    # and it is the closed loop: [q̇, M⁻¹(τ − h)] with τ = Kp (r t − q) − Kd q̇
    y = ys[0]
    tau = kp * (r * 1.7 - y[:4]) - kd * y[4:]
    qdd = arm.forward_dynamics(y[None, :4], y[None, 4:], tau[None], {"m3": 14.0})[0]
    np.testing.assert_allclose(f(1.7, y), np.r_[y[4:], qdd], rtol=1e-10, atol=1e-9)


def test_rigid_pd_rhs_is_the_old_formula_exactly():
    arm6 = physid.load_model("arm6")
    n = arm6.n_joints
    kp, kd = np.linspace(500, 4000, n), np.linspace(2, 150, n)
    f = pd_rhs(arm6, kp=kp, kd=kd, reference=lambda t: np.full(n, 0.3) * t, coulomb_smoothing=0.01)
    accel = arm6.make_rhs(None, coulomb_smoothing=0.01)
    y = np.random.default_rng(7).normal(size=2 * n)
    q, qd = y[:n], y[n:]
    old = np.concatenate([qd, accel(q, qd, kp * (np.full(n, 0.3) * 1.3 - q) - kd * qd)])
    np.testing.assert_array_equal(f(1.3, y), old)
    assert not hasattr(arm6, "make_pd_rhs")  # the model holds no controller any more


def test_closed_loop_generated_backend_uses_the_moved_law():
    arm = physid.load_model("manipulator")
    kp, kd = [3800.0, 40000.0, 10000.0, 500.0], [159.5, 120.0, 50.0, 2.0]
    ref = np.array([0.5, 0.4, 0.3, 0.2])
    f = closed_loop_rhs(arm, kp=kp, kd=kd, reference=lambda t: ref, backend="generated")
    g = pd_rhs(arm, kp=kp, kd=kd, reference=ref)
    y = np.linspace(-0.5, 0.5, 8)
    assert f.backend == "generated"
    assert f(0.2, y) == g(0.2, y)


# ------------------------------------------------------------------ one memory check
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


# ------------------------------------------------------------------ one save_figure
def _toy_trial(settings, seed):
    return {"mean": float(np.random.default_rng(seed).normal(settings["mu"], 1.0, 50).mean())}


def test_sweep_and_validation_figures_go_through_save_figure(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    import physid.report.style as style
    from physid.analysis.montecarlo import run_sweep
    from physid.analysis.sweep_table import write_sweep
    from physid.report.style import figure_png

    saved = []
    real = style.save_figure

    def spy(fig, path):
        saved.append(Path(path).name)
        return real(fig, path)

    monkeypatch.setattr(style, "save_figure", spy)
    res = run_sweep(_toy_trial, {"mu": [0.0, 1.0]}, trials=2, seed=1, scheduler="serial",
                    progress=False)  # fmt: skip
    fig = Figure(figsize=(3, 2))
    fig.add_subplot().plot([0, 1], [0, 1])
    paths = write_sweep(res, tmp_path, figures={"toy": fig})
    assert saved == ["toy.png"]
    assert paths["figure:toy"].read_bytes() == figure_png(fig)  # style.DPI, tight bounding box


# ------------------------------------------------------------------ warnings name flags on the CLI
def test_warning_names_python_argument_in_python_and_flag_on_the_cli(tmp_path, capsys):
    from physid.cli import main
    from physid.errors import PhysidWarning
    from physid.models.identifiability import (
        IdentifiabilityWarning,
        hold_plan,
        structural_identifiability,
    )
    from physid.signals import save_recording
    from physid.simulate.closed_loop import paper_manipulator_experiment

    arm = physid.load_model("manipulator")
    with pytest.warns(IdentifiabilityWarning) as record:
        hold_plan(structural_identifiability(arm), dict(arm.parameters, l1=0.41))
    (w,) = record.list
    assert isinstance(w.message, PhysidWarning)
    assert "Pass fixed={'l1': VALUE} with a measured value" in str(w.message)  # Python words

    path = tmp_path / "arm.csv"
    save_recording(paper_manipulator_experiment(kinetic="paper"), path)
    argv = ["identify", str(path), "--model", "manipulator", "--kinetic", "paper"]
    argv += ["--torque", "pd", "--half-width", "100", "--cutoff", "0.2", "--json"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if "m1*l1**2" in x and "warning" in x)
    assert line.startswith("physid: warning: m1 and l1 enter only as m1*l1**2")
    assert "Pass --fix l1=VALUE with a measured value" in line  # the verb's flag
    assert "fixed=" not in err and "\x1e" not in err


# ------------------------------------------------------------------ cache integrity before exec
PENDULUM = """
name = "pendulum_wave3_arch"
gravity = [0.0, -9.81, 0.0]
[parameters]
m = { value = 1.3, unit = "kg" }
l = { value = 0.7, unit = "m" }
[[joints]]
dh = { a = "l", alpha = 0 }
mass = "m"
"""


def test_tampered_cached_source_is_regenerated_and_never_runs(tmp_path, monkeypatch):
    from physid.models.chain import build_chain_model
    from physid.models.spec import parse_model_text

    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path / "cache"))
    first = build_chain_model(parse_model_text(PENDULUM, source="<test>"))
    assert not first.loaded_from_cache
    (entry_path,) = (tmp_path / "cache").glob("chain-*.json")
    entry = json.loads(entry_path.read_text())
    marker = tmp_path / "tampered-code-ran"
    evil = f"__import__('pathlib').Path({str(marker)!r}).write_text('ran')\n"
    entry["data"]["sources"]["tau"] = evil + entry["data"]["sources"]["tau"]
    entry_path.write_text(json.dumps(entry))  # format, key and the old sha256 kept

    second = build_chain_model(parse_model_text(PENDULUM, source="<test>"))
    assert not marker.exists()  # the altered source was refused before exec
    assert not second.loaded_from_cache  # ... and derived again
    q = np.array([[0.3]])
    # τ = m l² q̈ + m g l cos q (point mass at the link's end, gravity along −y)
    expected = 1.3 * 0.7**2 * 2.0 + 1.3 * 9.81 * 0.7 * np.cos(0.3)
    np.testing.assert_allclose(second.inverse_dynamics(q, 0 * q, q * 0 + 2.0), [[expected]],
                               rtol=1e-12)  # fmt: skip
    assert "__import__" not in json.loads(entry_path.read_text())["data"]["sources"]["tau"]
    third = build_chain_model(parse_model_text(PENDULUM, source="<test>"))
    assert third.loaded_from_cache  # the rewritten entry verifies


def test_cached_shared_library_is_verified_before_loading(tmp_path, monkeypatch):
    import subprocess
    import sys

    from physid.models.codegen import build_shared_library, compiler

    cache = tmp_path / "cache"
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(cache))
    good = "int answer(void) { return 7; }\n"
    if compiler() is None:  # nothing is built or loaded without a compiler
        assert build_shared_library(good, "wave3good") is None
        return
    # an earlier process built and cached the good library
    script = (
        "from physid.models.codegen import build_shared_library as b; "
        f"print(b({good!r}, 'wave3good').answer())"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.stdout.strip() == "7", done.stderr
    (lib_path,) = cache.glob("wave3good-*.so")
    marker = tmp_path / "tampered-library-ran"
    evil = (
        "#include <stdio.h>\n"
        "__attribute__((constructor)) static void run(void) {\n"
        f'  FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n'
        "int answer(void) { return 666; }\n"
    )
    assert build_shared_library(evil, "wave3evil").answer() == 666
    assert marker.exists()  # the evil library runs its constructor when it is loaded ...
    marker.unlink()
    (evil_path,) = cache.glob("wave3evil-*.so")
    lib_path.write_bytes(evil_path.read_bytes())  # ... and now sits in place of the good one
    again = build_shared_library(good, "wave3good")
    assert not marker.exists()  # the tampered file was never loaded
    assert again.answer() == 7  # it was rebuilt from the source


# ------------------------------------------------------------------ metadata
def test_pyproject_has_no_placeholder_urls():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib

    root = Path(__file__).resolve().parents[1]
    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    assert "urls" not in project  # no public repository exists: no invented links
    assert "invalid" not in (root / "pyproject.toml").read_text()
    assert project["authors"] and len(project["classifiers"]) >= 10
