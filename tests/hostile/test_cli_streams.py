"""The command's streams under hostile conditions: a reader that went away, an ASCII-only
terminal, a closed stderr, and model paths that are FIFOs or devices. Never a traceback."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

from physid.cli import BROKEN_PIPE_STATUS, main

SRC = str(Path(__file__).resolve().parents[2] / "src")


def _physid(argv, *, env=None, timeout=120, **kwargs):
    """``python -m physid ARGV`` in a subprocess with this checkout's sources first."""
    full = {**os.environ, **(env or {})}
    full["PYTHONPATH"] = os.pathsep.join(p for p in (SRC, full.get("PYTHONPATH")) if p)
    return subprocess.run(
        [sys.executable, "-m", "physid", *argv], env=full, timeout=timeout, **kwargs
    )


def _no_traceback(err: str) -> None:
    assert "Traceback" not in err
    assert "Exception ignored" not in err
    assert "Error:" not in err.replace("physid: error:", "")


# ------------------------------------------------------------------------- closed reader
def _into_closed_pipe(argv):
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader (e.g. `head -c 10`) has already gone
    try:
        return _physid(argv, stdout=write_end, stderr=subprocess.PIPE, text=True)
    finally:
        os.close(write_end)


def test_stdout_reader_gone_exits_quietly_with_141():
    done = _into_closed_pipe(["model", "info", "msd", "--json"])
    assert done.returncode == BROKEN_PIPE_STATUS == 141
    _no_traceback(done.stderr)


def test_help_into_a_closed_pipe_is_quiet():
    done = _into_closed_pipe(["--help"])
    assert done.returncode in (0, 141)  # argparse drops the help text itself: status 0
    _no_traceback(done.stderr)


def test_broken_pipe_in_process_returns_141(monkeypatch, capsys):
    class GoneReader(io.StringIO):
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self):
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", GoneReader())
    assert main(["model", "info", "msd", "--json"]) == 141


# ------------------------------------------------------------------------- ASCII terminal
def test_ascii_output_encoding_writes_escapes_not_a_traceback():
    done = _physid(
        ["model", "info", "manipulator"],
        env={"PYTHONIOENCODING": "ascii"},
        capture_output=True,
    )
    assert done.returncode == 0, done.stderr
    out = done.stdout.decode("ascii")  # every byte is ASCII
    assert "m/s\\xb2" in out  # m/s² with the ² escaped
    _no_traceback(done.stderr.decode("ascii", "replace"))


def test_ascii_stream_in_process_is_restored_afterwards(monkeypatch):
    raw = io.BytesIO()
    stream = io.TextIOWrapper(raw, encoding="ascii", errors="strict")
    monkeypatch.setattr(sys, "stdout", stream)
    assert main(["model", "info", "manipulator"]) == 0
    stream.flush()
    assert b"m/s\\xb2" in raw.getvalue()
    assert stream.errors == "strict"


# ------------------------------------------------------------------------- closed stderr
def test_progress_never_reaches_stdout_when_stderr_is_closed():
    done = _physid(
        ["model", "info", "msd", "--json"],
        stdout=subprocess.PIPE,
        preexec_fn=lambda: os.close(2),  # as `physid ... 2>&-`
    )
    assert done.returncode == 0
    info = json.loads(done.stdout)  # nothing but the JSON: no "physid model info: loaded" line
    assert info["name"] == "msd"


# ------------------------------------------------------------------------- model paths
def _limit_memory():
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (2 * 1024**3, 2 * 1024**3))


def test_model_path_that_is_a_fifo_is_refused(tmp_path):
    fifo = tmp_path / "model.toml"
    os.mkfifo(fifo)
    for argv in (["model", "info", str(fifo)], ["simulate", str(fifo), "--out", "x.csv"]):
        done = _physid(argv, capture_output=True, text=True, timeout=60, cwd=tmp_path)
        assert done.returncode == 2
        assert done.stderr.splitlines()[-1] == (
            f"physid: error: {str(fifo)!r} is a FIFO (named pipe), not a model file; give the "
            "path of a .toml or .urdf model file."
        )


def test_model_path_that_is_a_device_is_refused_before_reading(tmp_path):
    done = _physid(
        ["model", "info", os.devnull.replace("null", "zero")],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=_limit_memory,
    )
    assert done.returncode == 2
    assert "physid: error: '/dev/zero' is a character device, not a model file" in done.stderr


def test_load_model_refuses_a_fifo(tmp_path):
    """The library functions too (in a subprocess: opening a FIFO would block this one)."""
    fifo = tmp_path / "chain.toml"
    os.mkfifo(fifo)
    script = (
        "import sys\n"
        "from physid.errors import ModelFileError\n"
        "from physid.models import load_model, load_model_file\n"
        "for load in (load_model, load_model_file):\n"
        "    try:\n"
        "        load(sys.argv[1])\n"
        "    except ModelFileError as exc:\n"
        "        print(exc)\n"
    )
    full = {**os.environ, "PYTHONPATH": os.pathsep.join([SRC, os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run(
        [sys.executable, "-c", script, str(fifo)],
        env=full,
        capture_output=True,
        text=True,
        timeout=60,
    )
    expected = f"{str(fifo)!r} is a FIFO (named pipe), not a model file; give the path of a "
    assert done.stdout.count(expected) == 2, done.stdout + done.stderr
