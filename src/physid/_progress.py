"""Progress on stderr for work that can take more than a couple of seconds.

One small helper for every long step (excitation design, IV iterations, the identifiability
check, sweeps, long files): a counter with the time spent and the time left, redrawn in place on
a terminal. It never writes to stdout (that stays machine-readable) and is silent

* for work that ends within ``delay`` seconds (2 s): nothing to wait for, nothing printed;
* when stderr is not a terminal (a log file, a pipe, the tests), unless `configure` forces it;
* when the command line asked for quiet (``--quiet``), or for ``--json`` with stdout a pipe
  (`physid.cli.main` calls `configure(False)`).

The standard library is enough: a line ``label: 12/40 iterations, 3.1 s, about 7 s left``
rewritten with a carriage return, and a final line when the work is done.

Examples
--------
>>> import io
>>> stream = io.StringIO()
>>> with Progress(3, "design", unit="iterations", stream=stream, delay=0.0, force=True) as bar:
...     for _ in range(3):
...         bar.advance()
>>> stream.getvalue().rstrip().rsplit(chr(13), 1)[-1].split(",")[0]
'design: 3/3 iterations'
"""

from __future__ import annotations

import sys
import threading
import time

__all__ = ["configure", "is_enabled", "Progress", "working"]

_STATE: dict = {"enabled": None, "quiet": False}


def configure(enabled: bool | None, *, quiet: bool = False) -> None:
    """Switch progress on (True), off (False) or back to automatic (None: when stderr is a TTY).

    Parameters
    ----------
    enabled : bool or None
        The setting for this process (the ``physid`` command sets it from ``--quiet`` and
        ``--json``).
    quiet : bool
        Also silence the command's notes on stderr (``--quiet``); warnings and errors remain.
    """
    _STATE["enabled"] = None if enabled is None else bool(enabled)
    _STATE["quiet"] = bool(quiet)


def is_enabled(stream=None) -> bool:
    """Whether progress is shown on ``stream`` (default stderr).

    Parameters
    ----------
    stream : file-like, optional
        Where progress would go.

    Returns
    -------
    bool
        The `configure` setting, or, when automatic, whether ``stream`` is a terminal.
    """
    if _STATE["enabled"] is not None:
        return _STATE["enabled"]
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _seconds(s: float) -> str:
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


class Progress:
    """A counter with time left on stderr (a context manager).

    Parameters
    ----------
    total : int or None
        Steps expected (None: unknown; the line shows the count and the time spent only).
    label : str
        What is running (``"design-excitation"``).
    unit : str
        What a step is (``"iterations"``).
    delay : float
        Seconds [s] before the first line: quick work prints nothing.
    stream : file-like, optional
        Default ``sys.stderr`` (never stdout).
    force : bool
        Show it even where `is_enabled` says no (tests, doctests).
    """

    def __init__(self, total, label, *, unit="steps", delay=2.0, stream=None, force=False):
        self.total = None if total is None else max(int(total), 1)
        self.label = str(label)
        self.unit = str(unit)
        self.delay = float(delay)
        self.stream = sys.stderr if stream is None else stream
        self.enabled = bool(force) or is_enabled(self.stream)
        self.done = 0
        self.start = time.perf_counter()
        self._last = -1.0
        self._shown = False

    def line(self, now: float | None = None) -> str:
        """The text of the progress line (without the carriage return).

        Parameters
        ----------
        now : float, optional
            `time.perf_counter` value (default: now).

        Returns
        -------
        str
            ``"label: 3/10 iterations, 2 s, about 5 s left"``.
        """
        now = time.perf_counter() if now is None else now
        spent = now - self.start
        if self.total is None:
            return f"{self.label}: {self.done} {self.unit}, {_seconds(spent)}"
        text = f"{self.label}: {self.done}/{self.total} {self.unit}, {_seconds(spent)}"
        if 0 < self.done < self.total:
            left = spent * (self.total - self.done) / self.done
            text += f", about {_seconds(left)} left"
        return text

    def advance(self, n: int = 1) -> None:
        """Count ``n`` more steps done and redraw the line (at most ten times a second).

        Parameters
        ----------
        n : int
            Steps finished since the last call.
        """
        self.done += int(n)
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self.start < self.delay or now - self._last < 0.1:
            return
        self._last = now
        self._shown = True
        self.stream.write("\r" + self.line(now) + "\x1b[K")
        self.stream.flush()

    def close(self) -> None:
        """End the line (only if one was shown)."""
        if self.enabled and self._shown:
            self.stream.write("\r" + self.line() + "\x1b[K\n")
            self.stream.flush()
            self._shown = False

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class working:
    """Show the time spent on one long call that has no steps to count (a context manager).

    A thread redraws ``label: 12 s`` every half second once ``delay`` has passed, and the last
    line says how long it took; nothing is printed for a call shorter than ``delay``.

    Parameters
    ----------
    label : str
        What is running (``"identifiability check"``).
    delay : float
        Seconds [s] before the first line.
    stream : file-like, optional
        Default ``sys.stderr``.
    force : bool
        Show it even where `is_enabled` says no.
    """

    def __init__(self, label, *, delay=2.0, stream=None, force=False):
        self.label = str(label)
        self.delay = float(delay)
        self.stream = sys.stderr if stream is None else stream
        self.enabled = bool(force) or is_enabled(self.stream)
        self._stop = threading.Event()
        self._shown = False
        self._thread = None
        self.start = time.perf_counter()

    def _run(self) -> None:
        if self._stop.wait(self.delay):
            return
        while not self._stop.is_set():
            self._shown = True
            spent = time.perf_counter() - self.start
            self.stream.write(f"\r{self.label}: {_seconds(spent)} ...\x1b[K")
            self.stream.flush()
            self._stop.wait(0.5)

    def __enter__(self) -> working:
        self.start = time.perf_counter()
        if self.enabled:
            self._thread = threading.Thread(target=self._run, daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self._shown:
            spent = time.perf_counter() - self.start
            self.stream.write(f"\r{self.label}: done in {_seconds(spent)}\x1b[K\n")
            self.stream.flush()
