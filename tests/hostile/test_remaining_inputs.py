"""Hostile inputs: a model file's [recording] table, an interrupted sweep, a FIFO as the data file.

* an entry of a model file's ``[recording]`` table that does not fit the data file is reported as
  that table's entry (the model file, its line), never as a ``--map`` the user did not pass;
* a ``sweep --out DIR`` interrupted (Ctrl-C) leaves ``DIR`` as it was: nothing partial;
* a data file that is a FIFO (or another non-regular file) is refused before it is opened, so
  physid neither blocks on it nor calls it missing.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ._cases import case_ids, check_case

SRC = str(Path(__file__).resolve().parents[2] / "src")

_PENDULUM = (
    'name = "pendulum"\ngravity = [0, -9.81, 0]\n[parameters]\n'
    'm1 = { value = 2.0, unit = "kg" }\nl1 = { value = 0.5, unit = "m" }\n'
    '[[joints]]\ndh = { a = "l1" }\nmass = "m1"\n[recording]\n'
)  # the [recording] entry below is on line 10

TABLE_CASES = [
    # (case_id, [recording] entry, message_regex)
    ("table-unit-contradicts-file", 'q1 = "q1 [N]"',
     r"the \[recording\] table of \S*model\.toml \(line 10\) entry q1 = 'q1 \[N\]', but the file "
     r"says 'q1' is in \[rad\]"),
    ("table-unknown-unit", 'q1 = "q1 [furlong]"',
     r"the \[recording\] table of \S*model\.toml \(line 10\) entry q1 = 'q1 \[furlong\]'"),
    ("table-expression-syntax", 'q1 = "2*(q1"',
     r"the \[recording\] table of \S*model\.toml \(line 10\) entry q1: cannot parse"),
    ("table-time-expression", 't = "2*(t"',
     r"the \[recording\] table of \S*model\.toml \(line 10\) entry t: cannot parse"),
]  # fmt: skip


@pytest.mark.parametrize(("case_id", "entry", "message_regex"), TABLE_CASES,
                         ids=case_ids(TABLE_CASES))  # fmt: skip
def test_recording_table_errors_name_the_table(case_id, entry, message_regex, hostile):
    model = hostile.tmp / "model.toml"
    model.write_text(_PENDULUM + entry + "\n", encoding="utf-8")
    result = check_case(hostile, ["identify", "{arm_csv}", "--model", str(model)], 2, message_regex)
    assert "--map" not in result.err.splitlines()[-1].split(". ")[0]


# ------------------------------------------------------------------------------ a FIFO as data
def _python(argv, tmp_path):
    """``python ARGV`` in a subprocess with this checkout's sources first (a FIFO would block
    this process; the timeout turns a regression into a failure, not a hang)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([SRC, os.environ.get("PYTHONPATH", "")])}
    return subprocess.run(
        [sys.executable, *argv], env=env, cwd=tmp_path, capture_output=True, text=True, timeout=60
    )


FIFO_VERBS = [
    ("identify", ["identify", "{fifo}", "--model", "msd"]),
    ("filter", ["filter", "{fifo}", "--out", "{tmp}/out.csv"]),
]


@pytest.mark.parametrize(("verb", "argv"), FIFO_VERBS, ids=[v for v, _ in FIFO_VERBS])
def test_a_fifo_as_the_data_file_is_refused_by_name(verb, argv, tmp_path):
    fifo = tmp_path / "live.csv"
    os.mkfifo(fifo)
    args = [a.format(fifo=fifo, tmp=tmp_path) for a in argv]
    done = _python(["-m", "physid", *args], tmp_path)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (
        f"physid: error: {fifo}: is a FIFO (named pipe), not a recording file; physid reads "
        "recordings from regular files (save the stream to a file first)."
    )
    assert "Traceback" not in done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["live.csv"]  # nothing written


def test_load_recording_refuses_a_fifo_without_opening_it(tmp_path):
    fifo = tmp_path / "live.npz"
    os.mkfifo(fifo)
    script = (
        "import sys\n"
        "from physid.errors import DataFileError\n"
        "from physid.signals import load_recording\n"
        "try:\n"
        "    load_recording(sys.argv[1])\n"
        "except DataFileError as exc:\n"
        "    print(exc)\n"
    )
    done = _python(["-c", script, str(fifo)], tmp_path)
    assert done.stdout.startswith(f"{fifo}: is a FIFO (named pipe), not a recording file;"), (
        done.stdout + done.stderr
    )


# ------------------------------------------------------------------------------ interrupted sweep
_SWEEP = ["sweep", "msd", "--trials", "2", "--snr", "40", "--ratio", "1", "--duration", "2"]
_SWEEP += ["--scheduler", "serial", "--no-progress", "--quiet"]


def _tree(folder: Path) -> dict:
    """Every file under ``folder`` (hidden ones included) → its bytes; None when absent."""
    if not folder.exists():
        return None
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _interrupt(*args, **kwargs):
    raise KeyboardInterrupt


def _interrupt_trial(monkeypatch):
    import physid.analysis.msd_study as study

    real, calls = study.msd_trial, []

    def trial(settings, seed):
        calls.append(seed)
        if len(calls) == 2:  # the second trial: one has run
            raise KeyboardInterrupt
        return real(settings, seed)

    monkeypatch.setattr(study, "msd_trial", trial)


def _interrupt_figures(monkeypatch):
    import physid.report.style as style

    monkeypatch.setattr(style, "save_figure", _interrupt)  # the table and summary are written


def _interrupt_summary(monkeypatch):
    import physid.analysis.sweep_table as table

    real = table.atomic_write

    def write(path, *args, **kwargs):
        if Path(path).name == "summary.json":
            raise KeyboardInterrupt
        return real(path, *args, **kwargs)

    monkeypatch.setattr(table, "atomic_write", write)


INTERRUPTIONS = [
    ("in-a-trial", _interrupt_trial),
    ("writing-the-summary", _interrupt_summary),
    ("writing-the-figures", _interrupt_figures),
]


@pytest.mark.parametrize("earlier_run", [False, True], ids=["new-dir", "earlier-run"])
@pytest.mark.parametrize(("where", "patch"), INTERRUPTIONS, ids=[w for w, _ in INTERRUPTIONS])
def test_an_interrupted_sweep_leaves_its_out_dir_as_it_was(
    where, patch, earlier_run, tmp_path, monkeypatch, capsys
):
    from physid.cli import main

    out = tmp_path / "runs" / "sweep"
    if earlier_run:
        out.mkdir(parents=True)
        for name in ("trials.csv", "summary.json", "convergence_settle.png", "notes.txt"):
            (out / name).write_text(f"the earlier run's {name}\n", encoding="utf-8")
    before = _tree(out)
    patch(monkeypatch)
    assert main([*_SWEEP, "--out", str(out)]) == 130
    assert "physid: interrupted" in capsys.readouterr().err
    assert _tree(out) == before  # nothing partial, nothing of the earlier run lost
    assert [p.name for p in tmp_path.rglob("*") if p.is_file() or ".partial-" in p.name] == (
        [p.name for p in out.iterdir()] if earlier_run else []
    )  # no staging folder left behind


def test_a_sweep_moves_its_files_in_whole(tmp_path, capsys):
    from physid.cli import main

    out = tmp_path / "sweep"
    assert main([*_SWEEP, "--out", str(out)]) == 0
    capsys.readouterr()
    names = {p.name for p in out.iterdir()}
    assert {"trials.csv", "summary.json", "convergence_settle.png"} <= names
    assert [p.name for p in tmp_path.iterdir()] == ["sweep"]  # no staging folder left
    assert out.stat().st_mode & 0o777 == 0o777 & ~_umask()


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
