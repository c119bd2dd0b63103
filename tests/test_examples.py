"""Every script in examples/ runs on small data, exits 0 and prints its key result line; and
docs/cli.md documents every verb and option of the real parsers.

Each example reads ``PHYSID_EXAMPLE_QUICK=1`` to shrink its data, and runs with ``MPLBACKEND=Agg``
in a temporary working directory (so files it writes do not litter the repository).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES_DIR = Path(__file__).resolve().parents[1] / "examples"
EXAMPLES = sorted(EXAMPLES_DIR.glob("*.py"))

#: The line each example must print (a regular expression searched in stdout). The numbers are
#: checked too: an example whose estimate is off prints a different line and fails here.
KEY_LINES = {
    "identify_arm_from_csv.py": (
        r"identified m2 = 2[45]\.\d+ kg \(true 25 kg\), error [0-9.]+ %",
        r"all identifiable parameters within 1 % of the truth: yes",  # with the high cut-off
        r"m1 and l1 enter only as m1\*l1\*\*2",  # the identifiability finding is reported
        r"identified m1\*l1\*\*2 = (7\.9[5-9]|8\.0[0-4])\d* \(true 8\)",  # within ~0.6 %
    ),
    "track_changing_stiffness.py": (
        # within 1 % of the new stiffness at the end of the record
        r"final stiffness: algebraic (89[1-9]|90\d)\.\d N/m, RLS (89[1-9]|90\d)\.\d N/m "
        r"\(true 900 N/m\)",
        r"RLS: within 2 % of the new stiffness \d+\.\d\d s after the jump",
    ),
    "dask_sweep.py": (r"serial run gives the same table bit for bit",),
}


def test_the_examples_exist():
    names = {p.name for p in EXAMPLES}
    assert {"identify_arm_from_csv.py", "track_changing_stiffness.py"} <= names


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(script, tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg", PHYSID_EXAMPLE_QUICK="1")
    proc = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
        timeout=300,
    )
    assert proc.returncode == 0, (
        f"{script.name} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    )
    assert "Traceback" not in proc.stderr
    patterns = KEY_LINES.get(script.name, (r"\S",))
    for pattern in patterns:
        assert re.search(pattern, proc.stdout), (
            f"{script.name}: no line matching {pattern!r} in its output:\n{proc.stdout[-3000:]}"
        )


def _long_options(parser, prefix=()):
    """(verb path, option) for every long option of every (sub)parser below ``parser``."""
    import argparse

    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out.extend(_long_options(sub, (*prefix, name)))
        else:
            out.extend((prefix, o) for o in action.option_strings
                       if o.startswith("--") and o != "--help")
    return out


def test_cli_reference_documents_every_verb_and_option():
    """docs/cli.md stays in sync with the real parsers: every verb and long option appears."""
    from physid.cli import build_parser

    text = (EXAMPLES_DIR.parent / "docs" / "cli.md").read_text(encoding="utf-8")
    options = _long_options(build_parser())
    verbs = {path[0] for path, _ in options if path}
    assert {"demo", "simulate", "identify", "estimate", "sweep", "design-input"} <= verbs
    missing = []
    for path, option in options:
        if path and f"## physid {path[0]}" not in text:
            missing.append(f"section '## physid {path[0]}'")
        if not re.search(re.escape(option) + r"\b", text):
            missing.append(f"{' '.join(path)} {option}")
    assert not missing, f"docs/cli.md lacks: {sorted(set(missing))}"
