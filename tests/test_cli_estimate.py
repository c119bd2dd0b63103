"""The ``physid estimate`` verb (algebraic and rls methods)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from physid.cli import main
from physid.signals import Recording, save_recording
from physid.simulate import simulate_msd

OMEGA0 = math.sqrt(400.0 / 3.0)
ZETA = 0.3


@pytest.fixture(scope="module")
def msd_csv(tmp_path_factory):
    """Noise-free ζ = 0.3 MSD driven at 10 ω0 (exact simulation), 1 s at 1 kHz."""
    rec = simulate_msd(
        natural_frequency=OMEGA0,
        damping_ratio=ZETA,
        amplitude=1000 / 3,
        ratio=10.0,
        duration=1.0,
        dt=1e-3,
        x0=(0.01, 0.2),
    )
    return save_recording(rec, tmp_path_factory.mktemp("est") / "msd.csv")


def _json(capsys):
    return json.loads(capsys.readouterr().out)


def test_algebraic_json(msd_csv, capsys):
    assert (
        main(
            [
                "estimate",
                str(msd_csv),
                "--model",
                "msd",
                "--method",
                "algebraic",
                "--window",
                "0.05",
                "--json",
            ]
        )
        == 0
    )
    out = _json(capsys)
    assert set(out) >= {"parameters", "success", "message", "valid_fraction"}
    p = out["parameters"]
    assert set(p) == {"theta1", "theta2"}  # fitted only; ω0 and ζ are derived
    assert set(out) >= {"stderr", "units", "derived"}
    p = {**p, **out["derived"]}
    # CSV keeps ~16 significant digits, so the exact-rule accuracy survives the round trip
    assert p["natural_frequency"] == pytest.approx(OMEGA0, rel=1e-6)
    assert p["damping_ratio"] == pytest.approx(ZETA, rel=1e-5)
    assert p["theta1"] == pytest.approx(2 * ZETA * OMEGA0, rel=1e-5)
    assert out["success"] is True and 0.8 < out["valid_fraction"] <= 1.0


def test_algebraic_options_and_text_summary(msd_csv, capsys):
    argv = [
        "estimate",
        "--final",
        "lstsq",
        str(msd_csv),
        "--window",
        "0.06",
        "--mu",
        "4",
        "--integration",
        "simpson",
        "--block",
        "3",
        "--expanding",
    ]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "AlgebraicResult: success" in text and "natural_frequency" in text
    assert main([*argv, "--json"]) == 0
    # Simpson on a 60-sample window: coarser than the exact rule but within 1e-3
    assert _json(capsys)["derived"]["natural_frequency"] == pytest.approx(OMEGA0, rel=1e-3)


def test_unknown_and_known(msd_csv, capsys):
    assert (
        main(
            [
                "estimate",
                str(msd_csv),
                "--unknown",
                "theta2",
                "--known",
                f"theta1={2 * ZETA * OMEGA0!r}",
                "--json",
            ]
        )
        == 0
    )
    out = _json(capsys)
    p = out["parameters"]
    assert set(p) == {"theta2"}
    p = {**p, **out["derived"]}
    assert p["theta2"] == pytest.approx(OMEGA0**2, rel=1e-6)


def test_rls_method(msd_csv, capsys):
    assert main(["estimate", str(msd_csv), "--method", "rls", "--forgetting", "1.0", "--json"]) == 0
    out = _json(capsys)
    assert set(out["parameters"]) == {"theta1", "theta2"}
    assert set(out["derived"]) == {"natural_frequency", "damping_ratio"}
    assert out["derived"]["natural_frequency"] == pytest.approx(OMEGA0, rel=1e-2)


def test_third_order_model_file(tmp_path, capsys):
    toml = tmp_path / "third.toml"
    toml.write_text(
        'name = "third"\nkind = "linear_ode"\n[parameters]\n'
        "a0 = { value = 1.0 }\na1 = { value = 1.0 }\na2 = { value = 1.0 }\n"
        "b0 = { value = 20.0, identify = false }\n"
        '[ode]\na = ["a0", "a1", "a2"]\nb = ["b0"]\ninput = "u"\noutput = "y"\n'
    )
    # y''' + 8 y'' + 37 y' + 50 y = 20 u (poles −2, −3 ± 4j), exact response to two sinusoids
    a = np.array([50.0, 37.0, 8.0, 1.0])
    t = np.arange(0.0, 2.0, 1e-3)
    from scipy import signal

    u = 30 * np.sin(5 * t) + 20 * np.sin(13 * t + 1)
    sys = signal.StateSpace(*signal.tf2ss([20.0], a[::-1]))
    # lsim's first-order hold is exact for piecewise-linear u only: use a 0.1 ms grid, subsample
    tf = np.arange(0.0, 2.0, 1e-4)
    uf = 30 * np.sin(5 * tf) + 20 * np.sin(13 * tf + 1)
    y = signal.lsim(sys, uf, tf, interp=True)[1][::10]
    rec = Recording.from_columns(t, {"u": u, "y": y[: t.size]})
    path = save_recording(rec, tmp_path / "third.csv")
    assert main(["estimate", str(path), "--model", str(toml), "--window", "0.5", "--json"]) == 0
    p = _json(capsys)["parameters"]
    assert set(p) == {"a0", "a1", "a2"}
    for name, value in zip(("a0", "a1", "a2"), a[:3], strict=True):
        assert p[name] == pytest.approx(value, rel=1e-3), name


def test_errors(msd_csv, tmp_path, capsys):
    assert main(["estimate", str(msd_csv), "--window", "5"]) == 2
    assert "longer than the record" in capsys.readouterr().err
    assert main(["estimate", str(msd_csv), "--window", "0.003"]) == 2
    assert "kernels need at least" in capsys.readouterr().err
    assert main(["estimate", str(msd_csv), "--integration", "simpson", "--window", "0.051"]) == 2
    assert "even number of sample intervals" in capsys.readouterr().err
    assert main(["estimate", str(msd_csv), "--unknown", "omega"]) == 2
    assert "unknown coefficient name" in capsys.readouterr().err
    assert main(["estimate", str(msd_csv), "--method", "rls", "--window", "0.05"]) == 2
    assert "--window do(es) not apply to --method rls" in capsys.readouterr().err
    assert main(["estimate", str(msd_csv), "--forgetting", "0.99"]) == 2
    assert "--forgetting do(es) not apply" in capsys.readouterr().err
    t = np.arange(0.0, 0.5, 1e-3)
    zero = save_recording(
        Recording.from_columns(t, {"u": 0 * t, "x": 0 * t}), tmp_path / "zero.csv"
    )
    assert main(["estimate", str(zero)]) == 2
    assert "no excitation" in capsys.readouterr().err


def _third_order_named_channels(tmp_path):
    """y''' + 8 y'' + 37 y' + 50 y = 20 F with channels named F (input) and q (output)."""
    from scipy import signal

    toml = tmp_path / "third_fq.toml"
    toml.write_text(
        'name = "third_fq"\nkind = "linear_ode"\n[parameters]\n'
        "a0 = { value = 40.0 }\na1 = { value = 30.0 }\na2 = { value = 6.0 }\n"
        "b0 = { value = 20.0, identify = false }\n"
        '[ode]\na = ["a0", "a1", "a2"]\nb = ["b0"]\ninput = "F"\noutput = "q"\n'
    )
    a = np.array([50.0, 37.0, 8.0, 1.0])
    tf = np.arange(0.0, 2.0, 1e-4)  # lsim's hold is exact for piecewise-linear input: fine grid
    uf = 30 * np.sin(5 * tf) + 20 * np.sin(13 * tf + 1)
    y = signal.lsim(signal.StateSpace(*signal.tf2ss([20.0], a[::-1])), uf, tf, interp=True)[1]
    rec = Recording.from_columns(tf[::10], {"F": uf[::10], "q": y[::10]})
    return toml, save_recording(rec, tmp_path / "third_fq.csv"), a


@pytest.mark.parametrize("method", ["rls", "algebraic"])
def test_third_order_model_with_named_channels(tmp_path, capsys, method):
    """The estimators read the model's input_name / output_name (F, q), not u and x."""
    toml, path, a = _third_order_named_channels(tmp_path)
    extra = ["--window", "0.5"] if method == "algebraic" else []
    argv = ["estimate", str(path), "--model", str(toml), "--method", method, *extra, "--json"]
    assert main(argv) == 0
    p = _json(capsys)["parameters"]
    assert set(p) == {"a0", "a1", "a2"}
    for name, value in zip(("a0", "a1", "a2"), a[:3], strict=True):
        assert p[name] == pytest.approx(value, rel=1e-5), name


def test_missing_named_channel_is_reported(tmp_path, msd_csv, capsys):
    toml, _, _ = _third_order_named_channels(tmp_path)
    assert main(["estimate", str(msd_csv), "--model", str(toml), "--method", "rls"]) == 2
    assert "input channel 'F' and an output channel 'q'" in capsys.readouterr().err


@pytest.mark.parametrize("method", ["algebraic", "rls"])
def test_known_without_unknown_estimates_the_rest(msd_csv, capsys, method):
    theta1 = 2 * ZETA * OMEGA0
    argv = ["estimate", str(msd_csv), "--method", method, "--known", f"theta1={theta1!r}"]
    assert main([*argv, "--json"]) == 0
    out = _json(capsys)
    p = out["parameters"]
    assert set(p) == {"theta2"}
    p = {**p, **out["derived"]}
    assert p["theta2"] == pytest.approx(OMEGA0**2, rel=1e-3 if method == "rls" else 1e-6)
    assert p["damping_ratio"] == pytest.approx(ZETA, rel=1e-3)


def test_rls_init_samples_option(msd_csv, capsys):
    argv = ["estimate", str(msd_csv), "--method", "rls", "--init-samples", "5", "--json"]
    assert main(argv) == 0
    assert _json(capsys)["derived"]["natural_frequency"] == pytest.approx(OMEGA0, rel=1e-2)
    assert main(["estimate", str(msd_csv), "--init-samples", "5"]) == 2
    assert "--init-samples do(es) not apply to --method algebraic" in capsys.readouterr().err


def test_rls_errors(msd_csv, tmp_path, capsys):
    rls = ["estimate", str(msd_csv), "--method", "rls"]
    for bad in ("0", "1.5", "-0.2"):
        assert main([*rls, "--forgetting", bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("physid: error:") or "\nphysid: error:" in err
        assert "forgetting" in err and "must lie in (0, 1]" in err and "1 keeps all data" in err
    # 1 s at 1 kHz, the default cut-off's 240-sample transient: 760 rows < 1000 init samples
    assert main([*rls, "--init-samples", "1000"]) == 2
    err = capsys.readouterr().err
    assert "physid: error:" in err and "rows after the" in err and "fewer --init-samples" in err
    assert "init_samples" not in err  # the CLI user reads flags, not keywords
    assert main([*rls, "--init-samples", "1"]) == 2
    err = capsys.readouterr().err
    assert "--init-samples must be an integer >= 2" in err and "number of unknowns (2)" in err
    # a settled record (u ≡ 1, x ≡ 0.01 = u / θ2): the ẋ column is only filter residue
    t = np.arange(0.0, 2.0, 1e-3)
    const = save_recording(
        Recording.from_columns(t, {"u": np.ones_like(t), "x": np.full_like(t, 0.01)}),
        tmp_path / "const.csv",
    )
    assert main(["estimate", str(const), "--method", "rls"]) == 2
    err = capsys.readouterr().err
    assert "physid: error:" in err and "no excitation of theta1" in err and "--known" in err
    zero = save_recording(
        Recording.from_columns(t, {"u": 0 * t, "x": 0 * t}), tmp_path / "zero_rls.csv"
    )
    assert main(["estimate", str(zero), "--method", "rls"]) == 2
    assert "is zero over the whole record (no excitation)" in capsys.readouterr().err


def test_resample_accepts_a_jittered_record(tmp_path, capsys):
    """Sample times jittered by 1 % of Δ: refused by default, estimated with --resample."""
    rec = simulate_msd(
        duration=2.0, dt=1e-3, ratio=3.0, amplitude=100.0, natural_frequency=12.0, damping_ratio=0.3
    )
    t = rec.t + 1e-5 * np.sin(np.arange(rec.n_samples))  # ≤ 1 % of Δ = 1 ms
    t[0], t[-1] = rec.t[0], rec.t[-1]
    path = tmp_path / "jitter.csv"
    save_recording(Recording(t, rec.select(["u", "x"]), ["u", "x"]), path)
    assert main(["estimate", str(path), "--method", "algebraic", "--json"]) == 2
    assert "--resample" in capsys.readouterr().err
    assert main(["estimate", str(path), "--method", "algebraic", "--resample", "--json"]) == 0
    out = _json(capsys)
    assert out["derived"]["natural_frequency"] == pytest.approx(12.0, rel=1e-3)
    assert out["derived"]["damping_ratio"] == pytest.approx(0.3, rel=1e-2)


def test_rls_bias_compensation_flag_and_its_mention_in_cli_words(tmp_path, capsys):
    # the withholding reason names the flag, not a Python keyword the CLI has no flag for.
    import json

    from physid.cli import main

    rec = tmp_path / "m30.csv"
    assert main(["simulate", "msd", "--out", str(rec), "--snr", "30", "--seed", "1"]) == 0
    capsys.readouterr()
    base = ["estimate", str(rec), "--model", "msd", "--method", "rls", "--json"]
    assert main(base) == 0
    plain = json.loads(capsys.readouterr().out)
    assert plain["stderr"] is None
    assert "--bias-compensation" in plain["stderr_reason"]
    assert "bias_compensation=" not in plain["stderr_reason"]
    assert main([*base, "--bias-compensation"]) == 0
    comp = json.loads(capsys.readouterr().out)
    assert set(comp["stderr"]) == {"theta1", "theta2"}
    assert all(v > 0 for v in comp["stderr"].values())
    assert comp["parameters"]["theta2"] != plain["parameters"]["theta2"]
    argv = ["estimate", str(rec), "--model", "msd", "--method", "algebraic", "--bias-compensation"]
    assert main(argv) == 2
