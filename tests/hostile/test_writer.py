"""Outputs are written only to regular files: a symbolic link, FIFO or device in the way is
refused with its kind named, and left exactly as it was (never replaced by a regular file)."""

from __future__ import annotations

import os
import stat

import pytest

from physid._paths import atomic_write
from physid.errors import OutputError

from ._cases import run_cli

FIFO = r"it is a FIFO \(named pipe\), not a regular file; physid writes outputs by replacing"


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_symlink_destination_is_refused_and_kept(tmp_path):
    target = tmp_path / "target.csv"
    target.write_text("original\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    with pytest.raises(
        OutputError,
        match=r"cannot write '.*link\.csv': it is a symbolic link \(to '.*target\.csv'\); "
        r"give the target path",
    ):
        atomic_write(link, lambda fh: fh.write("new\n"))
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "original\n"
    assert _leftovers(tmp_path) == []


def test_dangling_symlink_destination_is_refused_and_kept(tmp_path):
    link = tmp_path / "dangling.csv"
    link.symlink_to(tmp_path / "nowhere" / "x.csv")
    with pytest.raises(OutputError, match=r"'.*dangling\.csv': it is a symbolic link"):
        atomic_write(link, lambda fh: fh.write("new\n"))
    assert link.is_symlink()


def test_fifo_destination_is_refused_and_kept(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(OutputError, match=rf"cannot write '.*pipe\.csv': {FIFO}"):
        atomic_write(fifo, lambda fh: fh.write("new\n"))
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert _leftovers(tmp_path) == []


def test_fifo_that_appears_while_writing_is_not_replaced(tmp_path):
    path = tmp_path / "late.csv"

    def write(fh):
        fh.write("data\n")
        os.mkfifo(path)  # someone puts a FIFO there while the data are being written

    with pytest.raises(OutputError, match=FIFO):
        atomic_write(path, write)
    assert stat.S_ISFIFO(os.lstat(path).st_mode)
    assert _leftovers(tmp_path) == []


def test_regular_file_is_still_replaced(tmp_path):
    path = tmp_path / "plain.csv"
    path.write_text("old\n")
    atomic_write(path, lambda fh: fh.write("new\n"))
    assert path.read_text() == "new\n"


def test_cli_out_fifo_is_refused_before_the_work(tmp_path):
    fifo = tmp_path / "out.csv"
    os.mkfifo(fifo)
    res = run_cli(["simulate", "msd", "--out", str(fifo)])
    assert res.code == 2
    assert res.err.splitlines()[-1].startswith("physid: error: cannot write")
    assert "it is a FIFO (named pipe), not a regular file" in res.err
    assert "samples" not in res.err  # refused before the simulation ran
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_cli_out_symlink_is_refused(tmp_path):
    target = tmp_path / "real.csv"
    target.write_text("t,u,x\n")
    link = tmp_path / "out.csv"
    link.symlink_to(target)
    res = run_cli(["simulate", "msd", "--out", str(link)])
    assert res.code == 2
    assert "it is a symbolic link" in res.err and "give the target path" in res.err
    assert link.is_symlink() and target.read_text() == "t,u,x\n"
