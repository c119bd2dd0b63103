"""physid model info and physid simulate MODEL for chain models."""

import json
from pathlib import Path

import numpy as np

import physid
from physid.cli import main

DATA = Path(__file__).parent / "data"


def test_model_info_json_for_the_builtin_arm(capsys):
    assert main(["model", "info", "arm6", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["kind"] == "RigidBodyModel"
    assert [j["type"] for j in info["joints"]] == ["revolute"] * 6
    assert info["joints"][3]["limits"]["effort"] == 28.0
    names = [p["name"] for p in info["parameters"]]
    assert names[:13] == "m1 mcx1 mcy1 mcz1 XX1 XY1 XZ1 YY1 YZ1 ZZ1 Ia1 Fv1 Fc1".split()
    units = {p["name"]: p["unit"] for p in info["parameters"]}
    assert units["XX2"] == "kg*m^2" and units["Fv1"] == "N*m*s/rad"
    base = info["base_parameters"]
    assert base["n_base"] == physid.load_model("arm6").base_parameters().n_base
    assert all(b["expression"] and b["words"] for b in base["base"])
    assert info["load_seconds"] >= 0


def test_model_info_text_for_a_urdf_and_the_paper_arm(capsys):
    assert main(["model", "info", str(DATA / "arm3_prismatic.urdf")]) == 0
    out = capsys.readouterr().out
    assert "2. reach [prismatic]" in out and "base parameters" in out
    assert main(["model", "info", "manipulator"]) == 0
    out = capsys.readouterr().out
    assert "m1*l1**2" in out


def test_simulate_any_chain_model(tmp_path, capsys):
    out = tmp_path / "p2.csv"
    argv = ["simulate", str(DATA / "planar2.urdf"), "--out", str(out), "--duration", "0.5"]
    assert main(argv + ["--kp", "100", "--kd", "10", "--reference", "0.1,0.2"]) == 0
    rec = physid.load_recording(out)
    assert {"q1", "q2", "qd1", "tau2", "r1"} <= set(rec.names)
    assert rec.metadata["kp"] == [100.0, 100.0]
    # a reference recording (r1, r2) drives the next run
    ref = tmp_path / "ref.csv"
    t = np.arange(0, 0.5001, 0.01)
    ref.write_text("t,r1,r2\n" + "".join(f"{x},{0.2 * np.sin(x)},{-0.1 * x}\n" for x in t))
    out2 = tmp_path / "p2b.csv"
    assert (
        main(["simulate", str(DATA / "planar2.urdf"), "--out", str(out2), "--reference", str(ref)])
        == 0
    )
    rec2 = physid.load_recording(out2)
    np.testing.assert_allclose(rec2["r2"][-1], -0.05, atol=1e-9)


def test_simulate_chain_errors(tmp_path, capsys):
    argv = ["simulate", str(DATA / "planar2.urdf"), "--out", str(tmp_path / "x.csv")]
    assert main(argv + ["--kp", "1,2,3"]) == 2
    assert "--kp expects 1 or 2 gains" in capsys.readouterr().err
    assert main(["simulate", "nonexistent.urdf", "--out", str(tmp_path / "y.csv")]) == 2
    assert "neither a built-in model" in capsys.readouterr().err
