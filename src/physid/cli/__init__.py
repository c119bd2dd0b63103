"""The ``physid`` command line: thin wrappers that parse, call the API and print.

Each verb lives in its own module ``physid/cli/verb_<name>.py`` exposing::

    ORDER: int                                  # position in ``physid --help``
    def register(subparsers) -> None            # adds its parser and sets ``func=run``
    def run(args) -> int                        # returns the exit status

Verbs are discovered by module name, so adding one never touches this file. Bad input raises a
`physid.PhysidError`; `main` prints it as ``physid: error: <message>`` and exits with status 2.

Library errors name Python arguments (``kp=[...]``), marked with `physid.errors.arg`; `main`
shows them with this verb's flags instead (``--kp a,b,...``): the mapping keyword → flag is
every option's ``dest`` → its first long option string, updated by the verb module's optional

    ARGUMENT_FLAGS: dict[str, str | None]       # keyword -> flag, e.g. {"fixed": "--fix"}

for keywords whose flag has another name (None: the verb has no flag for it).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import pkgutil
import signal
import sys
import threading
import warnings
from pathlib import Path

from .. import __version__
from ..errors import PhysidError

__all__ = ["main", "build_parser", "argument_flags"]


def _verb_modules():
    mods = []
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith("verb_"):
            mods.append(importlib.import_module(f"{__name__}.{info.name}"))
    return sorted(mods, key=lambda m: (getattr(m, "ORDER", 100), m.__name__))


class _Parser(argparse.ArgumentParser):
    """argparse with physid's error format: ``physid: error: <message>`` and exit status 2.

    Sub-parsers inherit the class, so a bad option of any verb reads like every other bad input;
    the usage line of the verb that was misused still comes first.
    """

    def error(self, message: str):
        self.print_usage(sys.stderr)
        verb = self.prog.removeprefix("physid").strip()
        where = f" {verb}:" if verb else ""
        self.exit(2, f"physid: error:{where} {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (all verbs registered).

    Returns
    -------
    argparse.ArgumentParser
        ``physid`` with one sub-parser per ``verb_<name>.py`` module.
    """
    parser = _Parser(
        prog="physid",
        description=(
            "Identify physical parameters (masses, lengths, stiffness, damping, natural frequency) "
            "of mechanical systems from measured motion and force signals."
        ),
        epilog="Run 'physid VERB --help' for the options of each verb. Docs: docs/index.md.",
    )
    parser.add_argument("--version", action="version", version=f"physid {__version__}")
    sub = parser.add_subparsers(dest="verb", metavar="VERB")
    for mod in _verb_modules():
        mod.register(sub)
    for verb_parser in sub.choices.values():
        _add_quiet(verb_parser)
    return parser


def _add_quiet(parser: argparse.ArgumentParser) -> None:
    """``--quiet`` on a verb and on each of its sub-parsers (``simulate msd ... --quiet``)."""
    if "--quiet" not in parser._option_string_actions:
        parser.add_argument(
            "--quiet",
            action="store_true",
            default=argparse.SUPPRESS,
            help="no progress or notes on stderr (warnings and errors still show)",
        )
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                _add_quiet(child)


def argument_flags(parser: argparse.ArgumentParser, args: argparse.Namespace) -> dict:
    """Python keyword → command-line flag for the verb that ``args`` ran.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The full parser from `build_parser`.
    args : argparse.Namespace
        Parsed arguments (``args.verb`` names the verb, ``args.func`` its ``run``).

    Returns
    -------
    dict
        ``{dest: "--option"}`` for each option of the verb, updated by the verb module's
        ``ARGUMENT_FLAGS``; used with `physid.errors.PhysidError.render`.
    """
    flags: dict[str, str | None] = {}
    parsers = [parser]
    while parsers:  # the verb's parser, and the sub-command's (``simulate msd``) within it
        for action in parsers.pop()._actions:
            if isinstance(action, argparse._SubParsersAction):
                chosen = action._name_parser_map.get(getattr(args, action.dest, None))
                if chosen is not None:
                    parsers.append(chosen)
                continue
            longs = [o for o in action.option_strings if o.startswith("--")]
            if longs and action.dest not in ("help", "version", argparse.SUPPRESS):
                flags.setdefault(action.dest, longs[0])
    if "channel_map" in flags:  # the library's channels={...} is the command line's --map
        flags.setdefault("channels", flags["channel_map"])
    module = sys.modules.get(getattr(getattr(args, "func", None), "__module__", "") or "")
    flags.update(getattr(module, "ARGUMENT_FLAGS", {}) or {})
    return flags


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is so that cleanup runs as for Ctrl-C (exit 143).

    A `KeyboardInterrupt` subclass: code that cleans up on Ctrl-C (the sweep's pool kills its
    workers, staged outputs are dropped) does the same on SIGTERM.
    """


_TERMINATING = {"pending": False}
#: Seconds after which a SIGTERM whose exception was swallowed is raised again.
_RETRY_S = 0.2


def _raise_terminated(signum, frame):
    _TERMINATING["pending"] = True
    # An exception raised in a signal handler is lost when the signal lands inside a callback
    # whose exceptions Python ignores (e.g. logging's after-fork handler while a pool worker is
    # forked): re-raise from an alarm until something handles it (see _retry_terminated).
    signal.setitimer(signal.ITIMER_REAL, _RETRY_S)
    raise Terminated()


def _retry_terminated(signum, frame):
    if not _TERMINATING["pending"]:
        return
    if isinstance(sys.exc_info()[1], Terminated):  # being handled: cleanup is running
        return
    signal.setitimer(signal.ITIMER_REAL, _RETRY_S)
    raise Terminated()


def _quiet_lost_terminated(unraisable):
    """A swallowed `Terminated` is retried, not reported as "Exception ignored in ..."."""
    if isinstance(unraisable.exc_value, Terminated):
        return
    sys.__unraisablehook__(unraisable)


@contextlib.contextmanager
def _sigterm_as_exception():
    """While a verb runs, SIGTERM raises `Terminated` (only possible in the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    previous_alarm = signal.signal(signal.SIGALRM, _retry_terminated)
    previous_hook, sys.unraisablehook = sys.unraisablehook, _quiet_lost_terminated
    try:
        yield
    finally:
        sys.unraisablehook = previous_hook
        _TERMINATING["pending"] = False
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGTERM, previous)
        signal.signal(signal.SIGALRM, previous_alarm)


#: Exit status after the reader of stdout went away (``physid ... | head``): 128 + SIGPIPE, what
#: a shell reports for a command that the signal ended.
BROKEN_PIPE_STATUS = 141


def _reopen_closed_fds() -> None:
    """A closed fd 0/1/2 (``2>&-``) is pointed at /dev/null, so that no file physid opens later
    takes its number and receives what is written to that stream."""
    import os

    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_RDWR)
            if null != fd:
                os.dup2(null, fd)
                os.close(null)


@contextlib.contextmanager
def _output_streams():
    """stdout and stderr as the command needs them, restored afterwards.

    * A missing stream (the process started with it closed: Python sets it to None, and
      ``print(file=None)`` would write to stdout) becomes /dev/null: progress never reaches
      stdout.
    * Characters the stream's encoding lacks (``PYTHONIOENCODING=ascii``: θ, ±, ·) are written as
      backslash escapes instead of raising `UnicodeEncodeError`.
    """
    import io
    import os

    saved = {}
    if sys.stdout is None or sys.stderr is None:
        _reopen_closed_fds()
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if stream is None:
            saved[name] = (None, None)
            setattr(sys, name, open(os.devnull, "w", encoding="utf-8"))  # noqa: SIM115
        elif isinstance(stream, io.TextIOWrapper) and stream.errors == "strict":
            saved[name] = (stream, stream.errors)
            stream.reconfigure(errors="backslashreplace")
    try:
        yield
    finally:
        for name, (stream, errors) in saved.items():
            if stream is None:
                getattr(sys, name).close()
                setattr(sys, name, None)
            else:
                with contextlib.suppress(ValueError, OSError):  # closed meanwhile
                    stream.reconfigure(errors=errors)


def _silence_stdout() -> None:
    """After a broken pipe: point stdout at /dev/null, so that the interpreter's final flush of
    what is still buffered does not fail again ("Exception ignored ... BrokenPipeError")."""
    import os

    try:
        fd = sys.stdout.fileno()
    except (AttributeError, ValueError, OSError):
        return  # not a file (a test's StringIO): nothing is flushed at exit
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, fd)
    os.close(null)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``physid`` command.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status: 0 success, 2 refused input (one ``physid: error:`` line on stderr),
        130 interrupted (Ctrl-C), 141 the reader of stdout went away (``physid ... | head``;
        quietly, as other Unix tools), 143 terminated (SIGTERM).
    """
    with _output_streams():
        try:
            try:
                return _main(argv)
            finally:
                sys.stdout.flush()  # a pipe buffers stdout: a closed reader shows up here
        except BrokenPipeError:
            _silence_stdout()
            return BROKEN_PIPE_STATUS


def _check_output_targets(args) -> None:
    """Refuse, before the verb runs, an output that is a device, FIFO, socket or a symbolic link
    to anything but a folder (`physid._paths.atomic_write` would refuse it after the work)."""
    import os

    from .._paths import _check_not_special
    from ._common import OUTPUT_OPTIONS

    for key in OUTPUT_OPTIONS:
        value = getattr(args, key, None)
        if isinstance(value, str) and value and not os.path.isdir(value):
            _check_not_special(Path(value))


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    from .._progress import configure

    # progress on stderr: never with --quiet, nor under --json when stdout is a pipe
    quiet = bool(getattr(args, "quiet", False))
    json_to_pipe = bool(getattr(args, "json", False)) and not _isatty(sys.stdout)
    configure(False if quiet or json_to_pipe else None, quiet=quiet)
    args.quiet = quiet
    try:
        return _run(parser, args)
    finally:
        configure(None)


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _run(parser, args) -> int:
    """Run the verb; print its errors and warnings in command-line words."""
    from ._common import check_outputs, cli_words, report_warnings

    caught: list = []
    flags = argument_flags(parser, args)  # keyword -> flag, for errors and warnings alike
    args.argument_flags = flags  # verbs that report warnings early (report_warnings(caught, args))
    try:
        # warnings (numpy's RuntimeWarnings, physid's own) are collected and printed as
        # "physid: warning: ..." lines, once each, instead of raw file:line text
        with _sigterm_as_exception(), warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            check_outputs(args)  # no --out/--plot may name an input file (every verb)
            _check_output_targets(args)  # ... nor a device, FIFO, socket or link to a file
            status = int(args.func(args) or 0)
        report_warnings(caught, flags)
        return status
    except Terminated:
        report_warnings(caught, flags)
        print("physid: terminated", file=sys.stderr)
        return 143
    except PhysidError as exc:
        report_warnings(caught, flags)
        print(f"physid: error: {cli_words(exc.render(flags))}", file=sys.stderr)
        return 2
    except (
        FileNotFoundError,
        FileExistsError,
        IsADirectoryError,
        NotADirectoryError,
        PermissionError,
    ) as exc:
        report_warnings(caught, flags)
        print(f"physid: error: {exc.strerror or exc}: {exc.filename}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("physid: interrupted", file=sys.stderr)
        return 130
