"""The hostile-input framework: run ``physid`` in-process on a table of hostile command lines.

A test module adds its cases as a table in ``tests/hostile/test_<subject>.py``::

    from ._cases import case_ids, check_case

    CASES = [
        # (case_id, argv, expected_exit, message_regex)
        ("snr-overflow", ["simulate", "msd", "--out", "{tmp}/x.csv", "--snr", "4000"], 2,
         r"--snr .* at most"),
    ]

    @pytest.mark.parametrize(("case_id", "argv", "expected_exit", "message_regex"), CASES,
                             ids=case_ids(CASES))
    def test_subject(case_id, argv, expected_exit, message_regex, hostile):
        check_case(hostile, argv, expected_exit, message_regex)

``argv`` items may hold placeholders, filled by `HostileEnv.expand`: ``{tmp}`` (a fresh folder of
the test), and input files built once per session and copied into ``{tmp}`` for each case:
``{msd_csv}`` (a 2 s MSD recording t, u, x), ``{msd_npz}`` (the same as .npz), ``{arm_csv}``
(a 0.3 s closed-loop run of the built-in 4-joint manipulator), ``{short_csv}`` (50 samples of
one channel), ``{model_toml}`` (a one-joint chain model file), ``{dir_csv}`` (an empty
folder named ``dir.csv``). A module may add its own with
``hostile.add_file(name, path)`` before calling `check_case`.

`check_case` asserts physid's promises for the command:

* the exit status is ``expected_exit`` (2 for refused input: never 1, never a traceback);
* for status 2 the last stderr line starts with ``physid: error:`` and there is one such line;
* ``message_regex`` is found (`re.search`, DOTALL) in stderr for status ≠ 0, else in
  stdout + stderr;
* no Python warning (numpy ``RuntimeWarning`` etc.) escaped: warnings are recorded while the
  command runs, and any recorded warning, or raw ``...Warning: ...`` text on stderr, fails the
  case (``physid main`` prints warnings as ``physid: warning: ...`` lines, which are allowed);
* no input file was changed (the placeholders' files are hashed before and after).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import re
import shutil
import string
import warnings
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["CliResult", "HostileEnv", "run_cli", "check_case", "case_ids", "python_words"]

# "file.py:12: RuntimeWarning: overflow ..." — what Python prints for an unhandled warning
_RAW_WARNING = re.compile(r"\b\w*Warning: ")

# Python argument syntax a command-line user must never be told to type: ``name=None``,
# ``final='median'``, ``channels={...}``, ``kp=[...]``, a dict literal ``{'u': 'Force'}``
_PYTHON_WORDS = re.compile(
    r"(?<![-\w.])[a-z_][a-z0-9_]*=(?:None\b|True\b|False\b|'|\"|\{|\[|\.\.\.)"
    r"|\{\s*'[^']*'\s*:|\{[A-Z_]+: [A-Z_]+\}"
)


# a URDF error quotes the file's own XML (<axis xyz="0 0 1"/>, value='nan'): that is the file's
# syntax, not Python's
_XML = re.compile(r"<[^<>]*>|\b(?:xyz|rpy|value|name|type|link|filename|lower|upper)='[^']*'")


_FOREIGN_CALL = re.compile(r"\b(?:numpy|np|scipy\.io)\.\w+\([^()]*\)")


def python_words(text: str) -> list[str]:
    """The pieces of Python argument syntax in ``text`` (empty when it speaks command line)."""
    lines = [_XML.sub("", line) if ".urdf" in line else line for line in text.splitlines()]
    # how to write a file with another tool (numpy.savez(path, t=..., x=...)) is that tool's code
    lines = [_FOREIGN_CALL.sub("", line) for line in lines]
    return [m.group(0) for line in lines for m in _PYTHON_WORDS.finditer(line)]


@dataclass(frozen=True)
class CliResult:
    """What one in-process ``physid`` run produced."""

    code: int
    out: str
    err: str
    warnings: tuple = ()


def run_cli(argv: list[str]) -> CliResult:
    """Run ``physid.cli.main(argv)`` in-process; capture stdout, stderr, warnings, exit status.

    A ``SystemExit`` (argparse) gives its code; any other exception propagates (a traceback is
    exactly what a hostile case must never produce, and pytest shows it best).
    """
    from physid.cli import main

    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in argv])
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    shown = tuple(f"{w.filename}:{w.lineno}: {w.category.__name__}: {w.message}" for w in caught)
    return CliResult(int(code or 0), out.getvalue(), err.getvalue(), shown)


def case_ids(cases) -> list[str]:
    """The ``ids=`` of a case table (its first column), checked unique."""
    ids = [c[0] for c in cases]
    dupes = sorted({i for i in ids if ids.count(i) > 1})
    if dupes:
        raise ValueError(f"duplicate hostile case ids: {dupes}")
    return ids


def _digest(path: Path) -> str:
    if path.is_dir():
        parts = sorted(
            (str(p.relative_to(path)), _digest(p)) for p in path.rglob("*") if p.is_file()
        )
        return hashlib.sha256(repr(parts).encode()).hexdigest()
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else "<missing>"


@dataclass
class HostileEnv:
    """Placeholders for one test: ``tmp`` (its own folder) and the session's input files."""

    tmp: Path
    sources: dict  # name -> callable() -> Path (built once per session)
    files: dict = field(default_factory=dict)  # name -> Path copied into tmp

    def add_file(self, name: str, path) -> Path:
        """Register an input file of the test as placeholder ``{name}`` (hashed as an input)."""
        self.files[name] = Path(path)
        return Path(path)

    def path(self, name: str) -> Path:
        """The per-test copy of session input ``name`` (built on first use)."""
        if name == "tmp":
            return self.tmp
        if name not in self.files:
            if name not in self.sources:
                raise KeyError(
                    f"unknown placeholder {{{name}}}; known: tmp, {', '.join(sorted(self.sources))}"
                    f"{', ' + ', '.join(sorted(self.files)) if self.files else ''}"
                )
            src = Path(self.sources[name]())
            dst = self.tmp / src.name
            if src.is_dir():
                shutil.copytree(src, dst)
            else:
                shutil.copyfile(src, dst)
            self.files[name] = dst
        return self.files[name]

    def expand(self, argv) -> list[str]:
        """Fill the ``{placeholders}`` of each argument."""
        out = []
        for arg in argv:
            arg = str(arg)
            names = [f for _, f, _, _ in string.Formatter().parse(arg) if f]
            out.append(arg.format(**{n: self.path(n) for n in names}) if names else arg)
        return out

    def inputs(self) -> dict:
        """Hashes of every input file used so far (to prove nothing was changed)."""
        return {name: _digest(p) for name, p in self.files.items()}


def check_case(env: HostileEnv, argv, expected_exit: int, message_regex: str) -> CliResult:
    """Run one hostile command line and assert physid's promises (see the module docstring)."""
    args = env.expand(argv)
    before = env.inputs()
    res = run_cli(args)
    shown = f"argv={args}\nexit={res.code}\nstdout:\n{res.out[-2000:]}\nstderr:\n{res.err[-2000:]}"
    assert res.code == expected_exit, f"exit status {res.code}, expected {expected_exit}\n{shown}"
    assert "Traceback (most recent call last)" not in res.err, shown
    if expected_exit == 2:
        lines = [line for line in res.err.splitlines() if line.strip()]
        assert lines and lines[-1].startswith("physid: error:"), shown
        assert sum(line.startswith("physid: error:") for line in lines) == 1, shown
    text = res.err if expected_exit != 0 else res.out + res.err
    assert re.search(message_regex, text, re.DOTALL), f"no match for {message_regex!r}\n{shown}"
    leaked = python_words(res.err)
    assert not leaked, f"Python argument syntax {leaked} on stderr (say it with flags)\n{shown}"
    assert not res.warnings, "warnings escaped:\n" + "\n".join(res.warnings) + "\n" + shown
    raw = [
        line
        for line in res.err.splitlines()
        if _RAW_WARNING.search(line) and not line.startswith("physid: warning:")
    ]
    assert not raw, f"raw warning text on stderr: {raw}\n{shown}"
    after = env.inputs()
    changed = sorted(n for n in before if before[n] != after.get(n))
    assert not changed, f"input file(s) {changed} were changed by the command\n{shown}"
    return res
