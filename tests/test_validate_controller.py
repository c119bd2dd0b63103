"""`physid validate --kp/--kd/--feedforward`: the controller of the closed-loop re-simulation,
from the flags, the result file or the held-out file's metadata, and where it came from."""

import contextlib
import io
import json
from pathlib import Path

import pytest

from physid.cli import main

URDF = str(Path(__file__).parent / "data" / "planar2.urdf")


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's own refusals (an unknown choice)
            code = exc.code
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """PD + g(q) logs of planar2 (the fit's, noise-free; a held-out one), the held-out log again
    without its metadata (a robot's CSV), an OLS fit and an IV fit given --kp/--kd."""
    d = tmp_path_factory.mktemp("controller")
    files = {k: str(d / f"{k}.csv") for k in ("fit", "held")}
    base = ["simulate", "model", URDF, "--feedforward", "gravity", "--duration", "6"]
    assert _run([*base, "--out", files["fit"]])[0] == 0
    assert _run([*base, "--noise-std", "1e-6", "--seed", "3", "--out", files["held"]])[0] == 0
    text = Path(files["held"]).read_text()
    meta = json.loads(text.splitlines()[0].removeprefix("# metadata:"))
    files["bare"] = str(d / "bare.csv")
    Path(files["bare"]).write_text("\n".join(text.splitlines()[1:]) + "\n")
    gains = {k: ",".join(repr(float(x)) for x in meta[k]) for k in ("kp", "kd")}
    files["ols"] = str(d / "ols.json")
    fit = ["identify", files["fit"], "--model", URDF]
    assert _run([*fit, "--method", "idim-ols", "--save", files["ols"]])[0] == 0
    files["iv"] = str(d / "iv.json")
    iv = [*fit, "--method", "idim-iv", "--kp", gains["kp"], "--kd", gains["kd"]]
    assert _run([*iv, "--save", files["iv"]])[0] == 0
    return files, gains


def _validate(argv):
    code, out, err = _run(["validate", *argv, "--json"])
    assert code == 0, err
    report = json.loads(out)
    (note,) = [n for n in report["notes"] if n.startswith("(b)")]
    return report, note


def test_gains_from_the_flags(logs):
    """A held-out CSV without metadata: (b) is skipped without gains; with --kp/--kd and
    --feedforward gravity it re-simulates the log to the noise (1e-6 rad); the wrong
    feed-forward or gains miss by far more."""
    files, gains = logs
    report, note = _validate([files["ols"], files["bare"]])
    assert note.startswith("(b) skipped") and report["output_relative_error"] == {}
    flags = ["--kp", gains["kp"], "--kd", gains["kd"]]
    report, note = _validate([files["ols"], files["bare"], *flags, "--feedforward", "gravity"])
    assert "controller tau = Kp (r - q) - Kd qd + g(q) with kp [205.2, 15.64] (from given)" in note
    assert "feed-forward from given" in note
    right = max(report["output_relative_error"].values())
    assert right < 1e-4
    report, note = _validate([files["ols"], files["bare"], *flags])  # PD alone: sags
    assert "controller tau = Kp (r - q) - Kd qd with" in note
    assert "feed-forward from none recorded" in note
    assert max(report["output_relative_error"].values()) > 100 * right
    doubled = ",".join(repr(2 * float(x)) for x in gains["kp"].split(","))
    report, _ = _validate([files["ols"], files["bare"], "--kp", doubled, "--kd", gains["kd"],
                           "--feedforward", "gravity"])  # fmt: skip
    assert max(report["output_relative_error"].values()) > 100 * right


def test_gains_from_the_result_file_and_the_metadata(logs):
    """The IV fit saved its --kp/--kd: validate uses them on a CSV without metadata; the OLS
    fit saved none: the held-out file's metadata gives them (and its feed-forward)."""
    files, _ = logs
    saved = json.loads(Path(files["iv"]).read_text())["gains"]
    assert saved["kp"][0] == pytest.approx(205.2301038950345)
    report, note = _validate([files["iv"], files["bare"], "--feedforward", "gravity"])
    assert "(from the result file)" in note and max(report["output_relative_error"].values()) < 1e-2
    report, note = _validate([files["ols"], files["held"]])
    assert "(from the held-out recording's metadata)" in note
    assert "feed-forward from the recording's metadata" in note
    assert max(report["output_relative_error"].values()) < 1e-4


@pytest.mark.parametrize(
    ("flags", "match"),
    [
        (["--kp", "1,2,3", "--kd", "1,1"], r"--kp must hold one value per joint \(2\).*got 3"),
        (["--kp", "1,x", "--kd", "1,1"], r"--kp expects comma-separated numbers.*'x'"),
        (["--kp", "10,10", "--kd", "1,-1"], r"--kd must be gains >= 0.*\[1.0, -1.0\]"),
        (["--feedforward", "torque"], r"--feedforward.*invalid choice"),
    ],
)
def test_bad_gains_are_refused_naming_the_flag(logs, flags, match):
    import re

    files, _ = logs
    code, _, err = _run(["validate", files["ols"], files["held"], *flags])
    assert code == 2 and re.search(match, err), err
    assert "Traceback" not in err
