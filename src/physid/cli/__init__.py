"""The ``physid`` command line: thin wrappers that parse, call the API and print.

Each verb lives in its own module ``physid/cli/verb_<name>.py`` exposing::

    ORDER: int                                  # position in ``physid --help``
    def register(subparsers) -> None            # adds its parser and sets ``func=run``
    def run(args) -> int                        # returns the exit status

Verbs are discovered by module name, so adding one never touches this file. Bad input raises a
`physid.PhysidError`; `main` prints it as ``physid: error: <message>`` and exits with status 2.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from .. import __version__
from ..errors import PhysidError

__all__ = ["main", "build_parser"]


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
    """The full argument parser (all verbs registered)."""
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
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``physid`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(args.func(args) or 0)
    except PhysidError as exc:
        print(f"physid: error: {exc}", file=sys.stderr)
        return 2
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        print(f"physid: error: {exc.strerror or exc}: {exc.filename}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("physid: interrupted", file=sys.stderr)
        return 130
