"""``physid identify FILES --each``: a fleet from the command line (physid.cli._fleet).

The summary and exit status, --json rows, --against, the outputs in --out, and every refusal of a
flag that does not apply (pytest.raises-style: the exit status and the message's words)."""

from __future__ import annotations

import json

import pytest

import physid
from _fleet_logs import MODEL, write_log
from _helpers import cli_output
from physid.estimators.idim import IDIMEstimator
from physid.estimators.results import save_result


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli-fleet")
    model = physid.load_model(MODEL)
    # one exciting trajectory for every robot, other noise (noise seed 2: no parameter of the
    # unchanged robot beyond z = 1.96; see tests/test_fleet.py for the rate over 40 seeds)
    paths = [write_log(folder / f"robot{k}.npz", model, seed=0, noise_seed=2 * k) for k in range(2)]
    heavy = write_log(folder / "heavy.npz", model, seed=0, noise_seed=3, params={"m2": 1.5})
    est = IDIMEstimator(model, "ols").fit(physid.load_recording(paths[0]))
    ref = folder / "reference.json"
    save_result(est.result_, ref, model=MODEL, recording=paths[0], model_options={})
    return folder, paths, heavy, str(ref)


def test_each_prints_the_table_and_exits_0_when_every_log_fits(logs, tmp_path):
    _, paths, heavy, ref = logs
    out = tmp_path / "fleet"
    argv = ["identify", *paths, heavy, "--model", MODEL, "--each", "--scheduler", "serial",
            "--out", out, "--against", ref]  # fmt: skip
    from physid.cli import main

    assert main([str(a) for a in argv]) == 0
    assert (out / "fleet.csv").is_file() and (out / "fleet.html").is_file()
    assert sorted(p.name for p in (out / "results").iterdir()) == [
        "heavy.json", "robot0.json", "robot1.json"
    ]  # fmt: skip


def test_each_summary_and_json(logs, tmp_path, capsys):
    _, paths, heavy, ref = logs
    argv = ["identify", *paths, heavy, "--model", MODEL, "--each", "--scheduler", "serial",
            "--out", tmp_path / "f", "--against", ref]  # fmt: skip
    code, out, err = cli_output(argv, capsys)
    assert code == 0, err
    lines = {line.split()[0]: line for line in out.splitlines() if line.startswith("  ")}
    assert "mcx1R" in lines["heavy.npz"] and "YY1R" in lines["heavy.npz"]
    assert lines["robot1.npz"].rstrip().endswith("none")
    assert "1.96·sqrt(se² + se_ref²)" in out
    code, out, err = cli_output([*argv, "--json"], capsys)
    doc = json.loads(out)
    assert code == 0 and doc["success"] is True and len(doc["rows"]) == 3
    assert doc["rows"][2]["log"] == heavy and "mcx1R" in doc["rows"][2]["moved"]
    assert {e["parameter"] for e in doc["moved"] if e["moved"]} == {"mcx1R", "YY1R"}


def test_a_failed_log_exits_1_with_its_reason(logs, tmp_path, capsys):
    _, paths, _, _ = logs
    rec = physid.load_recording(paths[1])
    one = tmp_path / "one.npz"
    physid.signals.save_recording(
        physid.signals.Recording(rec.t, rec.select(["q1", "tau1"]), ["q1", "tau1"]), one
    )
    argv = ["identify", paths[0], tmp_path / "gone.npz", one, "--model", MODEL, "--each",
            "--scheduler", "serial", "--out", tmp_path / "f"]  # fmt: skip
    code, out, err = cli_output(argv, capsys)
    assert code == 1
    line = next(x for x in out.splitlines() if "gone.npz" in x)
    assert line.split()[:2] == ["gone.npz", "failed"] and "no such file" in line
    line = next(x for x in out.splitlines() if x.split()[:1] == ["one.npz"])
    assert "lacks channel(s)" in line and "--map q2=" in line  # the reason in CLI words
    assert "2 failed" in out


def test_result_files_are_read_by_validate(logs, tmp_path, capsys):
    _, paths, _, _ = logs
    out = tmp_path / "f"
    cli_output(["identify", paths[0], "--model", MODEL, "--each", "--out", out], capsys)
    code, text, err = cli_output(["validate", out / "results" / "robot0.json", paths[1]], capsys)
    assert code == 0, err
    assert "validate" in text.lower() or "relative" in text.lower()


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--each", "--join", "--out", "x"], "--join with --each"),
        (["--each", "--save", "r.json", "--out", "x"], "--save with --each"),
        (["--each", "--joint", "--out", "x"], "--joint with --each"),
        (["--each", "--joints", "shoulder", "--out", "x"], "--joints with --each"),
        (["--each"], "--each needs --out DIR"),
        (["--each", "--out", "x", "--method", "input-error"], "--method input-error is not"),
        (["--scheduler", "local:2"], "--scheduler applies to a fleet"),
        (["--against", "ref.json"], "--against applies to a fleet"),
        (["--out", "x", "--scheduler", "local"], "--scheduler, --out apply to a fleet"),
        (["--each", "--out", "x", "--scheduler", "local:0"], "needs a worker count N >= 1"),
        (["--each", "--out", "x", "--stream", "on"], "--stream with --each"),
        (["--each", "--out", "x", "--block-samples", "7"], "--block-samples with --each"),
        (["--joint", "--scheduler", "serial", "--stream", "off"], "--stream off with --joint"),
        (["--each", "--out", "x", "--scheduler", "http://h:1"], "--scheduler 'http://h:1'"),
    ],
)
def test_flags_that_do_not_apply_are_refused(logs, tmp_path, capsys, monkeypatch, extra, words):
    _, paths, _, _ = logs
    monkeypatch.chdir(tmp_path)
    code, out, err = cli_output(["identify", *paths, "--model", MODEL, *extra], capsys)
    assert code == 2 and words in err, err
    assert "Traceback" not in err and not (tmp_path / "x").exists()


def test_out_that_is_a_file_is_refused(logs, tmp_path, capsys):
    _, paths, _, _ = logs
    (tmp_path / "taken").write_text("mine")
    code, _, err = cli_output(["identify", *paths, "--model", MODEL, "--each", "--out",
                               tmp_path / "taken"], capsys)  # fmt: skip
    assert code == 2 and "--out" in err and "existing file" in err
    assert (tmp_path / "taken").read_text() == "mine"


def test_a_reference_that_is_not_a_result_is_named(logs, tmp_path, capsys):
    _, paths, _, _ = logs
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2]")
    code, _, err = cli_output(["identify", *paths, "--model", MODEL, "--each", "--out",
                               tmp_path / "f", "--against", bad], capsys)  # fmt: skip
    assert code == 2 and f"--against {bad}" in err and "not a physid result file" in err
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"parameters": {"m1": 1.0}}))
    code, _, err = cli_output(["identify", *paths, "--model", MODEL, "--each", "--out",
                               tmp_path / "f", "--against", other], capsys)  # fmt: skip
    assert code == 2 and "--against" in err and "another model" in err
    assert not (tmp_path / "f").exists()


def test_an_unreachable_scheduler_is_a_clear_error(logs, tmp_path, capsys):
    pytest.importorskip("distributed", reason="Dask schedulers need physid[dask]")
    _, paths, _, _ = logs
    code, _, err = cli_output(["identify", *paths, "--model", MODEL, "--each", "--out",
                               tmp_path / "f", "--scheduler", "tcp://127.0.0.1:9",
                               "--scheduler-timeout", "2"], capsys)  # fmt: skip
    assert code == 2
    assert "could not reach the Dask scheduler at 'tcp://127.0.0.1:9' within 2 s" in err
    assert "--scheduler-timeout" in err and "--scheduler local" in err
    assert not (tmp_path / "f").exists()


@pytest.mark.parametrize("mode", [["--each", "--out", "f"], ["--joint"]])
def test_a_scheduler_address_without_a_port_is_a_clear_error(logs, tmp_path, capsys, mode):
    pytest.importorskip("distributed", reason="Dask schedulers need physid[dask]")
    _, paths, _, _ = logs
    mode = [str(tmp_path / m) if m == "f" else m for m in mode]
    code, _, err = cli_output(["identify", *paths, "--model", MODEL, *mode, "--scheduler",
                               "tcp://nohost", "--scheduler-timeout", "2"], capsys)  # fmt: skip
    assert code == 2 and "Traceback" not in err
    assert "--scheduler 'tcp://nohost' is not a Dask scheduler address" in err
    assert "missing port number" in err and "tcp://HOST:PORT" in err
    assert not (tmp_path / "f").exists()


def test_joint_is_the_default_for_several_files(logs, capsys):
    _, paths, _, _ = logs
    argv = ["identify", *paths, "--model", MODEL, "--json"]
    code, out, _ = cli_output(argv, capsys)
    code_joint, out_joint, _ = cli_output([*argv, "--joint"], capsys)
    assert code == code_joint == 0
    assert json.loads(out_joint)["parameters"] == json.loads(out)["parameters"]
    assert json.loads(out)["n_recordings"] == 2
