"""The hostile-input framework itself: it catches what it promises to catch."""

from __future__ import annotations

import pytest

from ._cases import case_ids, check_case, run_cli


def test_a_refused_command_passes_and_a_wrong_regex_fails(hostile):
    check_case(hostile, ["simulate", "msd", "--out", "{tmp}/x.csv", "--ratio", "-1"], 2, r"ratio")
    with pytest.raises(AssertionError, match="no match"):
        check_case(hostile, ["simulate", "msd", "--out", "{tmp}/x.csv", "--ratio", "-1"], 2, "zz")


def test_a_wrong_exit_status_fails(hostile):
    with pytest.raises(AssertionError, match="exit status 2, expected 0"):
        check_case(hostile, ["simulate", "msd", "--out", "{tmp}/x.csv", "--ratio", "-1"], 0, "")


def test_placeholders_copy_session_files_and_unknown_ones_are_named(hostile):
    argv = hostile.expand(["{msd_csv}", "{tmp}/out.csv"])
    assert argv[0].startswith(str(hostile.tmp)) and argv[0].endswith("msd.csv")
    with pytest.raises(KeyError, match="unknown placeholder"):
        hostile.expand(["{nope}"])


def test_a_changed_input_fails(hostile, monkeypatch):
    path = hostile.path("short_csv")
    import physid.cli

    real = physid.cli.main

    def clobber(argv):
        path.write_text(path.read_text("utf-8") + "\n", encoding="utf-8")
        return real(argv)

    monkeypatch.setattr(physid.cli, "main", clobber)
    with pytest.raises(AssertionError, match=r"input file\(s\) \['short_csv'\] were changed"):
        check_case(
            hostile, ["filter", "{short_csv}", "--half-width", "5", "--out", "{tmp}/o.csv"], 0, ""
        )


def test_escaped_warnings_are_recorded(monkeypatch):
    import warnings

    import physid.cli

    def noisy(argv):
        warnings.warn("overflow encountered", RuntimeWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(physid.cli, "main", noisy)
    res = run_cli([])
    assert res.code == 0 and "RuntimeWarning: overflow encountered" in res.warnings[0]


def test_case_ids_must_be_unique():
    with pytest.raises(ValueError, match="duplicate"):
        case_ids([("a", [], 2, ""), ("a", [], 2, "")])
