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
    "linear_axis_drive.py": (  # docs/your-data.md section 7: the documented commands
        r"identified m1 = (11\.99|12\.00)\d*, Fv1 = [78]\.\d+, Fc1 = [34]\.\d+, OF1 = 1\.[45]\d* ",
        r"held-out relative force error 0\.00\d+ \(stated: below 0\.005\)",
        r"within the ranges docs/your-data.md states: yes",
    ),
    "two_mass_chain.py": (
        r"every parameter within 1 % of the truth: yes",
        r"every truth inside its 95 % interval: yes",
        r"physid estimate exit status 0",
    ),
    "msd_force_sensor.py": (
        r"m = 2\.(49|50|51)\d* ± [0-9.]+ kg \(true 2\.5, error 0\.\d\d %\)",
        r"mass and stiffness within 1 % of the truth: yes",
        r"with u = F/m instead: m, c, k are not identifiable .* only 2 combination",
    ),
}


def test_the_examples_exist():
    names = {p.name for p in EXAMPLES}
    assert {"identify_arm_from_csv.py", "track_changing_stiffness.py"} <= names


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(script, tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg", PHYSID_EXAMPLE_QUICK="1")
    proc = subprocess.run(
        [sys.executable, str(script)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
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
            out.extend(
                (prefix, o) for o in action.option_strings if o.startswith("--") and o != "--help"
            )
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


def _documented_defaults(text):
    """{(verb, option): default cell} from the option tables of each ``## physid VERB`` section."""
    out = {}
    for section in re.finditer(r"^## physid (\S+)\n(.*?)(?=^## |\Z)", text, re.S | re.M):
        verb = section.group(1)
        for line in section.group(2).splitlines():
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            if len(cells) < 3 or not cells[0].startswith("`"):
                continue
            for option in re.findall(r"`([^`]+)`", cells[0]):
                out[(verb, option.split()[0])] = cells[1]
    return out


def _tokens(value) -> list[str]:
    if isinstance(value, (list, tuple)):
        return [str(v) for v in value]
    return [t for t in re.split(r"[,\s]+", str(value).strip()) if t]


def _same_default(documented: str, actual) -> bool:
    """Token by token: numbers compare as floats, anything else as text."""
    doc, act = _tokens(documented), _tokens(actual)
    if len(doc) != len(act):
        return False
    for d, a in zip(doc, act, strict=True):
        try:
            if float(d) != float(a):
                return False
        except ValueError:
            if d != a:
                return False
    return True


def _is_number_list(cell: str) -> bool:
    try:
        return all(float(t) == float(t) for t in _tokens(cell)) and bool(_tokens(cell))
    except ValueError:
        return False


def test_cli_reference_defaults_match_the_parsers():
    """Every default that docs/cli.md states is the parser's default.

    A number (or list of numbers) or a `literal` in the table's default column is compared with
    the argparse default; where that is None (the estimator resolves it), with the "(default X)"
    the option's --help states. "required" must be a required option, "off" a flag that is off,
    "none"/"—" an option without a default. Descriptive cells (e.g. "order + 1") are not checked.
    """
    import argparse

    from physid.cli import build_parser

    text = (EXAMPLES_DIR.parent / "docs" / "cli.md").read_text(encoding="utf-8")
    documented = _documented_defaults(text)
    actions = {}

    def walk(parser, prefix=()):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, (*prefix, name))
            elif prefix:
                for name in action.option_strings or [action.dest]:
                    actions.setdefault((prefix[0], name), []).append(action)

    walk(build_parser())
    checked, wrong = 0, []
    for key, cell in documented.items():
        for action in actions.get(key, []):
            literal = cell.startswith("`") and cell.endswith("`") and cell.count("`") == 2
            value = cell.strip("`")
            if cell == "required":
                ok = action.required
            elif cell == "off":
                ok = action.nargs == 0 and action.default in (False, None)
            elif cell in ("none", "—"):
                ok = action.default is None
            elif literal or _is_number_list(cell):
                actual = action.default
                if actual is None:
                    found = re.search(r"\(default:?\s+([^()]+?)\)", action.help or "")
                    actual = found.group(1) if found else None
                if actual is None:
                    wrong.append(f"{' '.join(key)}: documented {cell}, parser states none")
                    continue
                ok = _same_default(value, actual)
            else:
                continue
            checked += 1
            if not ok:
                wrong.append(
                    f"{' '.join(key)}: documented {cell!r}, parser default {action.default!r}, "
                    f"help {action.help!r}"
                )
    assert checked >= 40, f"only {checked} documented defaults were checked"
    assert not wrong, "docs/cli.md defaults differ from the parsers:\n" + "\n".join(wrong)
