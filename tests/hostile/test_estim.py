"""Hostile inputs of the linear-ODE estimators: never a wrong answer as success.

Each case: ``(case_id, argv, expected_exit, message_regex)``; ``{tmp}`` is the test's folder and
``{NAME}`` one of the files built below. Exit 2 is refused input (one ``physid: error:`` line),
1 a fit that ran and says why it failed.
"""

from __future__ import annotations

import contextlib
import io
import re
import warnings

import numpy as np
import pytest

from physid import Recording
from physid.signals import save_recording
from physid.simulate.msd import msd_paper_scenario

from ._cases import python_words

_TOML_SAME = (
    'name = "same"\nkind = "linear_ode"\n[parameters]\n'
    "theta2 = { value = 133.3, identify = true }\ntheta1 = { value = 0.0167, identify = true }\n"
    "b0 = { value = 1.0 }\n"
    '[ode]\na = ["theta2", "theta1"]\nb = ["b0"]\ninput = "x"\noutput = "x"\n'
)


def _files(tmp):
    t = np.arange(2000) * 1e-3
    rng = np.random.default_rng(3)
    files = {
        "msd_csv": save_recording(msd_paper_scenario(1.0, 60, duration=2.0, seed=1), tmp / "m.csv"),
        # a record that has settled: u ≡ 1, x ≡ 0.01 (θ1 is not excited)
        "const_csv": save_recording(
            Recording(t, np.c_[np.ones_like(t), np.full_like(t, 0.01)], ["u", "x"]), tmp / "c.csv"
        ),
        # independent white noise on both channels: no input-output relation at all
        "noise_csv": save_recording(
            Recording(t, rng.normal(size=(t.size, 2)), ["u", "x"]), tmp / "n.csv"
        ),
        # the output channel copied into the input column
        "copy_csv": save_recording(
            Recording(t, np.c_[np.sin(9 * t), np.sin(9 * t)], ["u", "x"]), tmp / "copy.csv"
        ),
    }
    (tmp / "same.toml").write_text(_TOML_SAME)
    files["same_toml"] = tmp / "same.toml"
    return files


CASES = [
    ("mu-40", ["estimate", "{msd_csv}", "--mu", "40"], 2, r"mu must be at most 20"),
    ("mu-100", ["estimate", "{msd_csv}", "--mu", "100"], 2, r"mu must be at most 20.*got mu = 100"),
    ("mu-ok", ["estimate", "{msd_csv}", "--mu", "8", "--json"], 0, r'"success": true'),
    ("const-alg", ["estimate", "{const_csv}"], 2, r"no excitation.*theta1|theta1.*no excitation"),
    (
        "const-rls",
        ["estimate", "{const_csv}", "--method", "rls"],
        2,
        r"no excitation.*theta1|theta1.*no excitation",
    ),
    ("noise-alg", ["estimate", "{noise_csv}"], 1, r"explains almost nothing"),
    ("noise-rls", ["estimate", "{noise_csv}", "--method", "rls"], 1, r"explains almost nothing"),
    ("copy-alg", ["estimate", "{copy_csv}"], 2, r"same signal up to a factor"),
    ("copy-rls", ["estimate", "{copy_csv}", "--method", "rls"], 2, r"same signal up to a factor"),
    (
        "input-is-output",
        ["estimate", "{msd_csv}", "--model", "{same_toml}"],
        2,
        r"input and output are the same channel 'x'",
    ),
    (
        "input-is-output-rls",
        ["estimate", "{msd_csv}", "--model", "{same_toml}", "--method", "rls"],
        2,
        r"input and output are the same channel 'x'",
    ),
    (
        "known-nan",
        ["estimate", "{msd_csv}", "--known", "theta1=nan"],
        2,
        r"(known values must be finite|theta1.*(finite|nan))",
    ),
    (
        "known-nan-rls",
        ["estimate", "{msd_csv}", "--known", "theta1=nan", "--method", "rls"],
        2,
        r"(known values must be finite|theta1.*(finite|nan))",
    ),
    ("validate-not-json", ["validate", "{msd_csv}", "{msd_csv}"], 2, r"not JSON|cannot read"),
]


def _run(argv):
    from physid.cli import main

    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in argv])
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 2
    return int(code or 0), out.getvalue(), err.getvalue(), caught


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return _files(tmp_path_factory.mktemp("estim_hostile"))


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=[c[0] for c in CASES]
)
def test_estim_hostile(case_id, argv, expected_exit, message_regex, files, tmp_path):
    argv = [a.format(tmp=tmp_path, **files) for a in argv]
    code, out, err, caught = _run(argv)
    assert code == expected_exit, (code, out, err)
    text = err if code else out + err
    assert re.search(message_regex, text, re.DOTALL), text
    if code == 2:
        lines = [ln for ln in err.splitlines() if ln.startswith("physid: error:")]
        assert len(lines) == 1 and err.strip().splitlines()[-1].startswith("physid: error:")
    numpy_warnings = [w for w in caught if issubclass(w.category, RuntimeWarning)]
    assert not numpy_warnings, [str(w.message) for w in numpy_warnings]
    assert python_words(err) == [], err  # command-line words only
