"""``physid --version`` and ``--help`` import nothing heavy.

Start-up time itself is measured in benchmarks/bench_cli.py (no timed assertions here); this
checks the cause structurally: after ``--version``, ``--help`` or a verb's ``--help`` none of
numpy, scipy, sympy, matplotlib, pandas is imported, so a new verb that imports one at module
level fails here.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("numpy", "scipy", "sympy", "matplotlib", "pandas", "pinocchio", "dask", "h5py")
PROBE = """
import contextlib, io, json, sys
from physid.cli import main
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        main(sys.argv[1:])
    except SystemExit:
        pass
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in HEAVY)))
"""


@pytest.mark.parametrize("argv", [["--version"], ["--help"], ["sweep", "--help"]])
def test_start_up_imports_nothing_heavy(argv):
    code = f"HEAVY = {HEAVY!r}\n{PROBE}"
    out = subprocess.run(
        [sys.executable, "-c", code, *argv], check=True, capture_output=True, text=True
    ).stdout
    assert json.loads(out.splitlines()[-1]) == []


def test_top_level_names_still_resolve():
    import physid

    assert physid.Recording.__name__ == "Recording"
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        physid.nope  # noqa: B018
