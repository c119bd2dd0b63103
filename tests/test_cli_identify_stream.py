"""``physid identify --stream``: a record fitted block by block from its file gives the in-memory
fit's estimate; ``--stream auto`` streams only above the memory rule; settings that cannot
stream are refused with the reason; a fleet's long log streams too.

Kinds of test (docs STYLE.md): equivalence of forms (streamed == in memory through the command
line, estimates to 1e-9 relative) and error paths (the refusals name the flag and the reason).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import physid
from physid.cli import main
from physid.simulate.closed_loop import simulate_closed_loop

KP = (3800.0, 40000.0, 10000.0, 500.0)
KD = (159.5, 120.0, 50.0, 2.0)
W0 = 2 * np.pi * np.array([0.2, 0.3, 0.5, 0.7])


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    model = physid.load_model("manipulator")
    t = np.arange(0.0, 8.0, 1e-3)
    ramp = np.clip(t, 0.0, 1.0)[:, None] ** 3
    ref = ramp * (0.8 * np.sin(np.outer(t, W0)) + 0.3 * np.sin(np.outer(t, 2.3 * W0) + 1))
    rec = simulate_closed_loop(model, kp=KP, kd=KD, reference=ref, t=t, noise_std=1e-4, rng=1)
    path = tmp_path_factory.mktemp("stream") / "run.h5"
    pytest.importorskip("h5py", reason="HDF5 needs physid[io]")
    import h5py

    with h5py.File(path, "w") as f:
        f["t"] = rec.t
        for name in rec.names:
            if name[0] in "qt":
                f[name] = rec[name]
    return str(path)


def _identify(capsys, *argv):
    code = main(["identify", *argv, "--model", "manipulator", "--json"])
    captured = capsys.readouterr()
    return code, (json.loads(captured.out) if captured.out.strip() else None), captured.err


def _values(out):
    return np.array([p["value"] for p in out["base_parameters"]])


def test_stream_on_gives_the_in_memory_estimate(log, capsys):
    code_mem, mem, _ = _identify(capsys, log, "--method", "idim-ols", "--stream", "off")
    code_st, st, err = _identify(
        capsys, log, "--method", "idim-ols", "--stream", "on", "--block-samples", "1500"
    )
    assert code_mem == code_st == 0
    assert [p["name"] for p in st["base_parameters"]] == [p["name"] for p in mem["base_parameters"]]
    np.testing.assert_allclose(_values(st), _values(mem), rtol=1e-9, atol=0)
    assert st["decimate"] == mem["decimate"] and st["cutoff"] == mem["cutoff"]
    assert "streamed in blocks of 1500 samples" in err


def test_stream_auto_streams_only_above_the_memory_rule(log, capsys, monkeypatch):
    from physid import _resources as resources

    _, _, err = _identify(capsys, log, "--method", "idim-ols")
    assert "block by block" not in err  # 8 s of a 4-joint arm: far below 2 GiB
    monkeypatch.setattr(resources, "STREAM_ABOVE", 1024)
    code, out, err = _identify(capsys, log, "--method", "idim-wls")
    assert code == 0 and "fitting block by block (--stream auto)" in err
    assert out["method"] == "idim-wls"


@pytest.mark.parametrize(
    ("extra", "reason"),
    [
        (["--method", "idim-iv", "--kp", "1,1,1,1", "--kd", "1,1,1,1"], "--method idim-iv reads"),
        (["--method", "idim-ols", "--stderr", "hac"], "--stderr hac"),
        (["--method", "idim-ols", "--consistent"], "--consistent"),
        (["--method", "idim-ols", "--detrend"], "--detrend"),
    ],
)
def test_stream_on_refuses_what_cannot_stream(log, capsys, extra, reason):
    code, _, err = _identify(capsys, log, *extra, "--stream", "on")
    assert code == 2
    assert "--stream on cannot stream this fit" in err and reason in err


def test_stream_on_refuses_a_file_that_cannot_be_read_in_blocks(tmp_path, capsys, monkeypatch):
    from scipy.io import savemat

    from physid.signals.io import block_readers

    path = tmp_path / "run.mat"
    savemat(path, {"t": np.arange(10) * 1e-3, "q1": np.zeros(10)})
    monkeypatch.setattr(block_readers, "MAX_WHOLE_MAT_BYTES", 16)  # a "large" v5 file
    code, _, err = _identify(capsys, str(path), "--method", "idim-ols", "--stream", "on")
    assert code == 2 and "v7.3" in err and "Traceback" not in err


def test_stream_options_are_refused_with_input_error(log, capsys):
    code, _, err = _identify(capsys, log, "--method", "input-error", "--stream", "on")
    assert code == 2 and "--stream" in err


def test_a_fleet_log_too_large_for_memory_is_fitted_block_by_block(log, monkeypatch):
    from physid import _resources as resources
    from physid.analysis import fleet

    memory = fleet.fit_one_log("manipulator", log, "idim-ols")
    monkeypatch.setattr(resources, "STREAM_ABOVE", 1024)
    streamed = fleet.fit_one_log("manipulator", log, "idim-ols")
    assert memory["status"] == streamed["status"] == "ok"
    assert streamed["n_samples"] == memory["n_samples"] == 8000
    names = [k for k in memory if k.endswith("_se")]
    for se in names:
        name = se[:-3]
        assert streamed[name] == pytest.approx(memory[name], rel=1e-9, abs=0)
    assert "every" in streamed["warnings"] or streamed["result"] is not None


def test_a_time_gap_met_while_streaming_is_worded_for_the_command_line(tmp_path, capsys):
    t = np.arange(0.0, 2.0, 1e-3)
    t[1200:] += 0.5
    q = np.column_stack([np.sin(t * (k + 1)) for k in range(4)])
    path = tmp_path / "gap.csv"
    header = "t," + ",".join([f"q{k}" for k in range(1, 5)] + [f"tau{k}" for k in range(1, 5)])
    np.savetxt(path, np.column_stack([t, q, q]), delimiter=",", header=header, comments="")
    code, _, err = _identify(capsys, str(path), "--method", "idim-ols", "--stream", "on")
    assert code == 2 and "Split the file at sample 1200" in err
    assert "--join" not in err  # refused with one file
    assert "uniform_rtol" not in err and "physid.signals" not in err


def test_a_fleet_log_streamed_keeps_every_setting_it_was_given(log, monkeypatch):
    from physid import _resources as resources
    from physid.analysis import fleet

    options = {"per_joint_variance": False, "check_condition": False}
    memory = fleet.fit_one_log("manipulator", log, "idim-wls", fit_options=options)
    monkeypatch.setattr(resources, "STREAM_ABOVE", 1024)
    streamed = fleet.fit_one_log("manipulator", log, "idim-wls", fit_options=options)
    assert memory["status"] == streamed["status"] == "ok"
    for name in [k[:-3] for k in memory if k.endswith("_se")]:
        assert streamed[name + "_se"] == pytest.approx(memory[name + "_se"], rel=1e-8, abs=0)


def test_motor_side_logs_fit_the_same_in_memory_streamed_and_in_a_fleet(tmp_path, monkeypatch):
    """A transmission's motor-side channels (qm, taum) become q and tau the same way for one
    fit, a streamed fit and a fleet's log (one conversion, `physid.signals.joint_side`)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from _wrist_logs import coupled, write_log
    from physid import _resources as resources
    from physid.analysis import fleet

    log = tmp_path / "wrist.csv"
    write_log(log, 1, 0.002)
    model = str(coupled(tmp_path))
    memory = fleet.fit_one_log(model, str(log), "idim-ols")
    assert memory["status"] == "ok", memory["reason"]
    monkeypatch.setattr(resources, "STREAM_ABOVE", 1024)
    streamed = fleet.fit_one_log(model, str(log), "idim-ols", workers=2)
    assert streamed["status"] == "ok", streamed["reason"]
    for se in [k for k in memory if k.endswith("_se")]:
        name = se[:-3]
        assert streamed[name] == pytest.approx(memory[name], rel=1e-8, abs=1e-12)


def test_block_samples_below_two_is_refused_before_anything_is_read(log, capsys):
    code, _, err = _identify(capsys, log, "--method", "idim-ols", "--block-samples", "1")
    assert code == 2 and "--block-samples must be an integer of at least 2" in err
    assert "streamed in blocks" not in err


def test_stream_obstacle_names_python_arguments_to_python_callers():
    from physid.errors import InputError
    from physid.estimators.idim.stream import stream_obstacle

    assert stream_obstacle("idim-wls", ["run.h5", "run.parquet"]) is None
    why = stream_obstacle("idim-ols", ["run.h5"], stderr="hac")
    assert str(InputError(why)).startswith("stderr='hac' estimates the residual's correlation")
    assert InputError(why).render({"stderr": "--stderr"}).startswith("--stderr hac estimates")
    assert str(InputError(stream_obstacle("idim-iv", []))).startswith("method='idim-iv' reads")
    assert "detrend=True subtracts" in str(InputError(stream_obstacle("idim-ols", [], detrend=1)))
    assert "cannot be read in blocks" in stream_obstacle("idim-ols", ["run.xlsx"])
