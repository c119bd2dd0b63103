"""Output paths of the verbs are checked before any work: a folder output that is a file, a
recording output with another suffix or in a missing folder."""

from __future__ import annotations

import re

import pytest

from physid.cli import main


@pytest.mark.parametrize(
    "argv",
    [
        ["validate", "RESULT", "REC", "--plot", "FILE"],
        ["sweep", "msd", "--snr", "25", "--ratio", "1", "--trials", "1", "--out", "FILE"],
    ],
)
def test_folder_outputs_that_are_files_are_refused_first(tmp_path, capsys, argv):
    # checked late, validate --plot FILE gives a FileExistsError traceback after the work, and
    # sweep --out FILE runs every trial before refusing, in Python words (out_dir).
    from physid.cli import main

    existing = tmp_path / "notadir.txt"
    existing.write_text("mine\n")
    result = tmp_path / "r.json"
    result.write_text("{}")  # never read: the output is refused first
    rec = tmp_path / "h.csv"
    rec.write_text("t,q1\n0,0\n0.1,0\n")
    subst = {"RESULT": str(result), "REC": str(rec), "FILE": str(existing)}
    assert main([subst.get(a, a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "is an existing file, not a folder" in err and "Traceback" not in err
    assert existing.read_text() == "mine\n"


@pytest.fixture
def no_work(monkeypatch):
    """Make the simulation and the design fail loudly if they are reached."""
    import physid.analysis.excitation as excitation
    import physid.simulate as simulate

    def boom(*args, **kwargs):
        raise AssertionError("the work ran before --out was checked")

    monkeypatch.setattr(simulate, "simulate_closed_loop", boom)
    monkeypatch.setattr(excitation, "design_excitation", boom)


@pytest.mark.parametrize("verb", [["simulate", "arm6"], ["design-excitation", "arm6"]])
@pytest.mark.parametrize(
    ("out", "message"),
    [
        ("x.txt", r"--out 'x.txt': recordings are written as \.csv or \.npz; got suffix '\.txt'"),
        ("missing/x.csv", r"--out 'missing/x.csv': the folder .* does not exist"),
    ],
)
def test_recording_outputs_are_checked_before_the_work(
    tmp_path, monkeypatch, capsys, no_work, verb, out, message
):
    monkeypatch.chdir(tmp_path)
    assert main([*verb, "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.startswith("physid: error: ") and err.count("\n") == 1, err
    assert re.search(message, err), err
