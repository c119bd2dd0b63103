import subprocess
import sys

import physid
from physid.cli import main


def test_version_and_help(capsys):
    try:
        main(["--version"])
    except SystemExit as exc:
        assert exc.code == 0
    assert physid.__version__ in capsys.readouterr().out


def test_python_m_physid_runs():
    out = subprocess.run([sys.executable, "-m", "physid", "--help"], capture_output=True, text=True)
    assert out.returncode == 0
    assert "physid" in out.stdout


def test_no_verb_exits_2(capsys):
    assert main([]) == 2
