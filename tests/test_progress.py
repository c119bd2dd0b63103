"""The progress helper: a counter with time left on stderr, silent where it must be."""

from __future__ import annotations

import io
import time

import pytest

from physid import _progress
from physid._progress import Progress, configure, is_enabled, working


class _Terminal(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture(autouse=True)
def _automatic():
    configure(None)
    yield
    configure(None)


def test_silent_when_stderr_is_not_a_terminal():
    stream = io.StringIO()
    assert not is_enabled(stream)
    with Progress(10, "work", stream=stream, delay=0.0) as bar:
        for _ in range(10):
            bar.advance()
    assert stream.getvalue() == ""


def test_a_terminal_gets_the_counter_and_time_left():
    stream = _Terminal()
    bar = Progress(10, "design", unit="starts", stream=stream, delay=0.0)
    bar.done = 4
    # 4 of 10 done in 8 s: 6 left at 2 s each = 12 s
    assert bar.line(bar.start + 8.0) == "design: 4/10 starts, 8 s, about 12 s left"
    bar.done = 10
    assert bar.line(bar.start + 200.0) == "design: 10/10 starts, 3.3 min"
    unknown = Progress(None, "reading", unit="rows", stream=stream)
    unknown.done = 7
    assert unknown.line(unknown.start + 1.0) == "reading: 7 rows, 1 s"


def test_quick_work_prints_nothing_and_long_work_ends_its_line():
    stream = _Terminal()
    with Progress(3, "quick", stream=stream, delay=5.0) as bar:
        bar.advance(3)
    assert stream.getvalue() == ""
    stream = _Terminal()
    with Progress(3, "slow", stream=stream, delay=0.0) as bar:
        for _ in range(3):
            time.sleep(0.11)
            bar.advance()
    text = stream.getvalue()
    assert text.endswith("\n") and "slow: 3/3 steps" in text.rsplit("\r", 1)[-1]


def test_configure_false_silences_a_terminal_and_none_restores_it():
    stream = _Terminal()
    configure(False)
    assert not is_enabled(stream)
    configure(None)
    assert is_enabled(stream)


def test_working_reports_time_spent_only_after_the_delay():
    stream = _Terminal()
    with working("check", stream=stream, delay=1.0):
        pass
    assert stream.getvalue() == ""
    stream = _Terminal()
    with working("check", stream=stream, delay=0.05):
        time.sleep(0.3)
    assert "check: done in 0 s" in stream.getvalue()


def test_cli_quiet_silences_notes_and_resets_afterwards(tmp_path, capsys):
    from physid.cli import main

    out = tmp_path / "m.csv"
    assert main(["simulate", "msd", "--out", str(out), "--duration", "1"]) == 0
    loud = capsys.readouterr().err
    assert loud.strip()  # the command says what it wrote
    assert main(["simulate", "msd", "--out", str(out), "--duration", "1", "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert str(out) in captured.out or out.exists()
    assert _progress._STATE == {"enabled": None, "quiet": False}


def test_cli_json_to_a_pipe_turns_progress_off(monkeypatch):
    from physid.cli import main, verb_model

    seen = {}

    def spy(args):
        seen["enabled"] = is_enabled(_Terminal())
        return 0

    monkeypatch.setattr(verb_model, "run_info", spy)  # registered when main builds the parser
    # pytest's captured stdout is not a terminal: a pipe
    assert main(["model", "info", "manipulator", "--json"]) == 0
    assert seen["enabled"] is False
    assert main(["model", "info", "manipulator"]) == 0
    assert seen["enabled"] is True  # no --json: a terminal on stderr gets progress
    assert is_enabled(_Terminal())  # back to automatic after the command


def _slow_reader(monkeypatch, seconds=0.3):
    """Make every recording read take ``seconds`` and show its progress after 0.05 s."""
    import physid.signals as signals
    from physid.cli import _recordings

    real = signals.load_recording

    def slow(*args, **kwargs):
        time.sleep(seconds)
        return real(*args, **kwargs)

    monkeypatch.setattr(signals, "load_recording", slow)
    monkeypatch.setattr(_recordings, "READ_DELAY", 0.05)


def _small_csv(tmp_path):
    from physid.cli import main

    path = tmp_path / "long.csv"
    assert main(["simulate", "msd", "--out", str(path), "--duration", "1", "--quiet"]) == 0
    return path


def test_a_long_read_shows_progress_on_stderr_never_on_stdout(tmp_path, capsys, monkeypatch):
    import argparse

    from physid.cli._recordings import read_recording

    path = _small_csv(tmp_path)
    capsys.readouterr()
    _slow_reader(monkeypatch)
    configure(True)  # as on a terminal
    rec = read_recording(argparse.Namespace(file=str(path)))
    captured = capsys.readouterr()
    assert rec.t.size == 1001  # 1 s at the default 1 ms
    assert captured.out == ""
    assert "physid: reading long.csv: done in 0 s" in captured.err
    assert "physid: reading long.csv: 0 s ..." in captured.err  # the line while it reads
    configure(False)  # --quiet, or --json to a pipe
    read_recording(argparse.Namespace(file=str(path)))
    assert capsys.readouterr().err == ""


def test_cli_quiet_silences_the_reading_progress_on_a_terminal(tmp_path, capsys, monkeypatch):
    import sys

    from physid.cli import main

    path = _small_csv(tmp_path)
    out = tmp_path / "f.csv"
    _slow_reader(monkeypatch)
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    argv = ["filter", str(path), "--half-width", "5", "--out", str(out)]
    assert main(argv) == 0
    assert "physid: reading long.csv: done in" in terminal.getvalue()
    assert "reading" not in capsys.readouterr().out
    terminal.truncate(0)
    terminal.seek(0)
    assert main([*argv, "--quiet"]) == 0
    assert "reading" not in terminal.getvalue()
