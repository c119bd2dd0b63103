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


def test_a_file_that_appears_while_writing_is_not_replaced_without_overwrite(tmp_path, monkeypatch):
    """``overwrite=False`` holds to the end: a file created between the check and the rename
    is kept, and the refusal is the one an existing file gets."""
    import physid.signals.writers as writers
    from physid.errors import DataFileError
    from physid.signals import Recording, save_recording

    path = tmp_path / "rec.csv"

    def write(fh):
        fh.write("data\n")
        path.write_text("someone else's\n")  # appears while the data are being written

    with pytest.raises(FileExistsError):
        atomic_write(path, write, exclusive=True)
    assert path.read_text() == "someone else's\n"
    assert _leftovers(tmp_path) == []

    path.unlink()
    real = writers.atomic_write

    def late(dest, fill, **kwargs):  # the file appears after write_recording's own check
        def fill_then_appear(fh):
            fill(fh)
            dest.write_text("someone else's\n")

        return real(dest, fill_then_appear, **kwargs)

    monkeypatch.setattr(writers, "atomic_write", late)
    rec = Recording(t=[0.0, 0.1, 0.2], data=[[1.0], [2.0], [3.0]], names=["x"])
    with pytest.raises(DataFileError, match=r"rec\.csv exists; pass overwrite=True"):
        writers.write_recording(rec, path, overwrite=False)
    assert path.read_text() == "someone else's\n"
    assert _leftovers(tmp_path) == []
    monkeypatch.undo()
    save_recording(rec, path)  # overwrite=True (the default) still replaces it
    assert path.read_text().startswith("# metadata")


def test_replacing_a_private_file_keeps_it_private(tmp_path):
    """A 0600 destination stays 0600 when it is replaced; a new file gets open()'s mode."""
    path = tmp_path / "private.csv"
    path.write_text("old\n")
    os.chmod(path, 0o600)
    old = os.umask(0o022)
    try:
        atomic_write(path, lambda fh: fh.write("new\n"))
        atomic_write(tmp_path / "new.csv", lambda fh: fh.write("new\n"))
    finally:
        os.umask(old)
    assert path.read_text() == "new\n"
    assert stat.S_IMODE(os.lstat(path).st_mode) == 0o600
    assert stat.S_IMODE(os.lstat(tmp_path / "new.csv").st_mode) == 0o644


def test_the_umask_is_read_without_changing_it(monkeypatch):
    """Where /proc shows the umask it is read there: os.umask (not thread-safe) is not called."""
    from physid import _paths

    if not os.path.exists("/proc/self/status"):
        assert _paths._current_umask() == os.umask(os.umask(0o022))
        return
    old = os.umask(0o027)
    try:
        calls = []
        monkeypatch.setattr(_paths.os, "umask", lambda m: calls.append(m) or 0)
        assert _paths._current_umask() == 0o027
        assert calls == []
    finally:
        monkeypatch.undo()
        os.umask(old)
