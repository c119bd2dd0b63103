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


def test_bad_option_reads_like_every_other_bad_input(capsys):
    """argparse's own errors carry physid's prefix, name the verb, and exit with status 2."""
    import pytest

    with pytest.raises(SystemExit) as exc:
        main(["simulate", "manipulator", "--out", "x.csv", "--kinetic", "bogus"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "physid: error: simulate manipulator: argument --kinetic: invalid choice" in err
    with pytest.raises(SystemExit) as exc:
        main(["no-such-verb"])
    assert exc.value.code == 2
    assert "physid: error: argument VERB: invalid choice" in capsys.readouterr().err
