"""Errors raised by physid.

Every error says what was received, what was expected and how to fix it. Each class also derives
from the builtin a caller would naturally catch (``ValueError`` or ``TypeError``), so code written
against plain Python exceptions keeps working.

How an error names an argument (library words vs command-line words)
--------------------------------------------------------------------
A library message names *Python* arguments (``kp=[...]``, ``fixed={'l1': VALUE}``), never a
command-line flag: a Python user never reads ``--kp``. The ``physid`` command shows the same
error with *flags* (``--kp a,b,...``, ``--fix l1=VALUE``): a CLI user never reads ``kp=``.

To make that possible a message marks each argument reference with `arg`::

    raise InputError(
        f"{arg('kp')} must hold one gain per joint; pass {arg('kp', '[...]', cli='a,b,...')}."
    )

``str(error)`` (what Python shows) renders a mark as ``kp`` or ``kp=[...]``; the names are kept
in ``error.arguments`` (in order, without repeats) and the unrendered text in
``error.template``. ``error.render(flags)`` renders the marks with a mapping *keyword → flag*
instead: ``--kp`` or ``--kp a,b,...`` (the CLI value text, defaulting to the Python one; empty
for a switch). A name
missing from ``flags`` keeps its Python spelling, so a partial mapping is never wrong, only
Python-worded. `physid.cli.main` builds that mapping per verb from its argparse options
(``dest`` → option string) plus the verb module's optional ``ARGUMENT_FLAGS`` dict (keyword →
flag, or None for a keyword the verb has no flag for) and prints ``error.render(flags)``.
Warnings do the same: a warning class derived from `PhysidWarning` takes marked messages, and the
command prints ``warning.render(flags)`` on its ``physid: warning:`` lines.

The `physid._validate` helpers mark the argument name they are given, so every shape, range and
integer check is translated without extra work at the call site. Errors survive pickling (sweep
workers send them between processes) with their template and arguments.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

__all__ = [
    "PhysidError",
    "PhysidWarning",
    "InputError",
    "ShapeError",
    "SamplingError",
    "DataFileError",
    "ModelFileError",
    "ExpressionError",
    "OutputError",
    "IdentifiabilityError",
    "EstimationError",
    "SimulationError",
    "MissingDependencyError",
    "SchedulerError",
    "arg",
]

# Control characters that never occur in a message's own text delimit an argument mark:
# MARK name SEP python-value SEP cli-value MARK (empty value: a bare reference to the name).
_MARK = "\x1e"
_SEP = "\x1f"
_MARK_RE = re.compile(f"{_MARK}([^{_MARK}{_SEP}]*){_SEP}([^{_MARK}]*?){_SEP}([^{_MARK}]*){_MARK}")


def arg(name: str, value: str | None = None, *, cli: str | None = None) -> str:
    """Mark a reference to the Python argument ``name`` inside an error message.

    Parameters
    ----------
    name : str
        The keyword argument, as a Python caller spells it (``"kp"``, ``"fixed"``).
    value : str, optional
        Example value text in Python syntax (``"[...]"``, ``"{'l1': VALUE}"``). Without it the
        mark stands for the bare name.
    cli : str, optional
        The same value as the command line spells it (``"a,b,..."``, ``"l1=VALUE"``); defaults to
        ``value``; ``""`` for a flag that takes no value (``resample=True`` → ``--resample``).

    Returns
    -------
    str
        Marked text to embed in the message of a `PhysidError`; ``str(error)`` shows
        ``name`` or ``name=value``, ``error.render(flags)`` shows ``--flag`` or ``--flag cli``.

    Examples
    --------
    >>> e = InputError(f"pass {arg('fixed', '{NAME: VALUE}', cli='NAME=VALUE')} to hold it")
    >>> str(e)
    'pass fixed={NAME: VALUE} to hold it'
    >>> e.render({"fixed": "--fix"})
    'pass --fix NAME=VALUE to hold it'
    >>> e.arguments
    ('fixed',)
    """
    value = "" if value is None else str(value)
    cli = value if cli is None else str(cli)
    for text in (name, value, cli):
        if _MARK in text or _SEP in text:
            raise ValueError("arg() text must not contain the mark characters \\x1e or \\x1f")
    return f"{_MARK}{name}{_SEP}{value}{_SEP}{cli}{_MARK}"


def _render(template: str, flags: Mapping[str, str | None] | None) -> str:
    def one(match: re.Match) -> str:
        name, value, cli = match.groups()
        flag = flags.get(name) if flags else None
        if flag:
            return f"{flag} {cli}" if cli else flag
        return f"{name}={value}" if value else name

    return _MARK_RE.sub(one, template)


def _rebuild(cls, args, state):
    err = cls.__new__(cls)
    err.args = args
    err.__dict__.update(state)
    return err


class _Marked:
    """Argument marks in a message (see the module docstring): shared by errors and warnings."""

    def __init__(self, *args, arguments=()):
        template = args[0] if args and isinstance(args[0], str) else None
        names = []
        if template is not None and _MARK in template:
            names = [m.group(1) for m in _MARK_RE.finditer(template)]
            args = (_render(template, None), *args[1:])
        super().__init__(*args)
        self.template = template if template is not None else (str(args[0]) if args else "")
        self.arguments = tuple(dict.fromkeys([*names, *arguments]))

    def render(self, flags: Mapping[str, str | None] | None = None) -> str:
        """The message with argument marks rendered as flags.

        Parameters
        ----------
        flags : mapping of str to str or None, optional
            Python keyword → command-line flag (``{"kp": "--kp", "fixed": "--fix"}``); names
            that are missing or map to None keep their Python spelling.

        Returns
        -------
        str
            The message; ``render()`` with no mapping equals ``str(error)``.
        """
        if len(self.args) != 1 or _MARK not in self.template:
            return str(self)
        return _render(self.template, flags)

    def __reduce__(self):
        return _rebuild, (type(self), self.args, dict(self.__dict__))


class PhysidError(_Marked, Exception):
    """Base class of every error physid raises on purpose.

    Parameters
    ----------
    message : str
        The message; argument references may be marked with `arg` (see the module docstring).
    *args
        Further positional arguments, kept in ``args`` as for any exception.
    arguments : sequence of str, optional
        Python argument names the error is about, in addition to the ones marked in the message.

    Attributes
    ----------
    arguments : tuple of str
        Python argument names the message refers to.
    template : str
        The message with its argument marks (equal to ``str(error)`` when it has none).
    """


class PhysidWarning(_Marked, UserWarning):
    """Base class of physid's warnings whose message may name arguments (marked with `arg`).

    ``str(warning)`` names Python arguments (``cutoff='auto'``); the ``physid`` command prints
    ``warning.render(flags)`` on its ``physid: warning:`` lines (``--cutoff auto``), exactly as it
    does for errors.

    Parameters
    ----------
    message : str
        The message, argument references marked with `arg`.
    *args
        Further positional arguments, kept in ``args``.
    arguments : sequence of str, optional
        Python argument names the warning is about, besides the marked ones.

    Attributes
    ----------
    arguments : tuple of str
        Python argument names the message refers to.
    template : str
        The message with its argument marks.

    Examples
    --------
    >>> w = PhysidWarning(f"or use {arg('cutoff', repr('auto'), cli='auto')}")
    >>> str(w)
    "or use cutoff='auto'"
    >>> w.render({"cutoff": "--cutoff"})
    'or use --cutoff auto'
    """


class InputError(PhysidError, ValueError):
    """An argument has a value outside its allowed range or set."""


class ShapeError(PhysidError, ValueError):
    """An array has the wrong shape, or arrays that must agree in length do not."""


class SamplingError(PhysidError, ValueError):
    """A time vector is not strictly increasing, not uniform, or too short for the request."""


class DataFileError(PhysidError, ValueError):
    """A recording file cannot be read: missing columns, bad cells, unsupported format."""


class ModelFileError(PhysidError, ValueError):
    """A model file (TOML) is malformed: unknown symbol, bad transform, missing value."""


class ExpressionError(PhysidError, ValueError):
    """User-written arithmetic (a model expression, a channel map) is refused by the parser.

    Raised by `physid.expressions`. Besides the message, ``reason`` says why in one word
    (``"syntax"``, ``"forbidden"``, ``"too_large"``, ``"unknown_name"``, ``"unknown_function"``,
    ``"not_callable"``, ``"arguments"``, ``"not_finite"``, ``"invalid"``, ``"type"``,
    ``"argument"``), ``names`` holds the offending names, ``text`` the expression and ``source``
    where it was written, so that callers can reword the message for their context.
    """

    def __init__(self, message: str, *, reason: str = "invalid", names=(), text="", source=""):
        super().__init__(message)
        self.reason = reason
        self.names = tuple(names)
        self.text = text
        self.source = source

    def __reduce__(self):  # keep the keywords through pickling (process pools)
        return (
            _rebuild_expression_error,
            (str(self), self.reason, self.names, self.text, self.source),
        )


def _rebuild_expression_error(message, reason, names, text, source):
    return ExpressionError(message, reason=reason, names=names, text=text, source=source)


class OutputError(PhysidError, OSError):
    """An output cannot be written where it was asked: the path is a folder, is one of the
    inputs, or its folder is not writable. The message names the user's path, never a temporary
    file."""


class IdentifiabilityError(PhysidError, ValueError):
    """The data or the model cannot determine a parameter (singular regressor or Jacobian)."""


class EstimationError(PhysidError, ValueError):
    """An estimator cannot run on the given data (no excitation, too few rows)."""


class SimulationError(PhysidError, RuntimeError):
    """The integrator failed (stiff system, blow-up); the message says which settings to change."""


class MissingDependencyError(PhysidError, ImportError):
    """An optional dependency (Dask, h5py, pinocchio ...) is needed for the requested feature.

    The message names the extra to install, e.g. ``pip install "physid[dask]"``.
    """


class SchedulerError(PhysidError, ConnectionError):
    """A Dask scheduler cannot be reached (wrong address, not running, or too slow to answer).

    The message names the address and the timeout, and how to change them.
    """
