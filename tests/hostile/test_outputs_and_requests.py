"""Hostile command lines: outputs that would destroy an input or name a
temporary file, SNRs that overflow, requests too large to allocate, figure paths that are not
images, filters that leave nothing, list options with holes, model files that carry code, and
runs that must repeat bit for bit."""

from __future__ import annotations

import tempfile

import pytest

from ._cases import case_ids, check_case, run_cli

_SIM = ["simulate", "msd", "--duration", "1", "--out", "{tmp}/x.csv"]
_SWEEP = ["sweep", "msd", "--ratio", "1", "--trials", "1", "--duration", "1", "--out", "{tmp}/sw"]
_FILTER = ["filter", "{msd_csv}", "--half-width", "5"]

CASES = [
    # --- an output that resolves to an input is refused before anything is read or written
    ("out-is-input", [*_FILTER, "--out", "{msd_csv}"], 2, r"--out '.*msd\.csv' is the input file"),
    (
        "out-is-input-relative-spelling",
        [*_FILTER, "--out", "{tmp}/./msd.csv"],
        2,
        r"writing it would destroy the input\. Choose another output, e\.g\. --out '.*msd-out",
    ),
    ("out-is-input-npz", ["filter", "{msd_npz}", "--out", "{msd_npz}"], 2, r"is the input file"),
    # --- an output that is a folder, or lies under a file: the user's path, not a temp file
    (
        "out-is-a-folder",
        [*_FILTER, "--out", "{dir_csv}"],
        2,
        r"cannot write '[^']*dir\.csv': it is a folder; give a file name, e\.g\. '.*dir\.csv/out",
    ),
    (
        "out-under-a-file",
        [*_FILTER, "--out", "{short_csv}/o.csv"],
        2,
        r"cannot write '.*short\.csv/o\.csv': '.*short\.csv' is a file, not a folder",
    ),
    ("sim-out-is-a-folder", [*_SIM[:-1], "{dir_csv}"], 2, r"it is a folder; give a file name"),
    # --- SNRs whose amplitude 10**(snr/10) overflowed a double (OverflowError, exit 1)
    ("snr-3083", [*_SIM, "--snr", "3083"], 2, r"(snr_db|--snr) must lie in \[-300, 350\] dB"),
    ("snr-1e6", [*_SIM, "--snr", "1e6"], 2, r"must lie in \[-300, 350\] dB; got 1000000"),
    ("snr-minus-7000", [*_SIM, "--snr", "-7000"], 2, r"must lie in \[-300, 350\]"),
    # --- list options with holes or non-finite items (25,,80 was read as [25, 80])
    ("snr-list-hole", [*_SWEEP, "--snr", "25,,80"], 2, r"--snr .* item 2 of '25,,80' is empty"),
    ("snr-list-trailing", [*_SWEEP, "--snr", "25,"], 2, r"item 2 of '25,' is empty"),
    (
        "forgetting-hole",
        ["design-input", "msd", "--forgetting", "0.9,,1"],
        2,
        r"--forgetting .* item 2 of '0\.9,,1' is empty\. Remove the extra comma",
    ),
    (
        "forgetting-nan",
        ["design-input", "msd", "--forgetting", "0.9,nan"],
        2,
        r"--forgetting expects finite numbers; got 'nan'",
    ),
    # --- requests too large to allocate: refused with the number, before allocating
    (
        "design-samples-1e8",
        ["design-input", "msd", "--samples", "100000000"],
        2,
        r"needs about [\d.]+ [GTP]B of memory, more than half of the .* available; lower samples",
    ),
    (
        "design-samples-work",
        ["design-input", "msd", "--samples", "20000"],
        2,
        r"evaluates about [\d.e+]+ terms .*Lower --samples",
    ),
    # --- a figure path that is not an image (matplotlib's ValueError after the whole run)
    (
        "design-plot-csv",
        ["design-input", "msd", "--plot", "{tmp}/x.csv"],
        2,
        r"--plot '.*x\.csv' is not a PNG file name: .*the suffix must be \.png; got '\.csv'",
    ),
    ("design-plot-no-suffix", ["design-input", "msd", "--plot", "{tmp}/x"], 2, r"got 'none'"),
    # --- a filter that leaves fewer than 2 samples wrote a file physid could not read back
    (
        "filter-leaves-1-sample",
        ["filter", "{msd_csv}", "--half-width", "1000", "--out", "{tmp}/o.csv"],
        2,
        r"--half-width 1000 leaves 1 output sample\(s\) of the 2001 .*at most 999",
    ),
    (
        "filter-paper-leaves-0",
        ["filter", "{msd_csv}", "--half-width", "1000", "--paper", "--out", "{tmp}/o.csv"],
        2,
        r"leaves 0 output sample\(s\).*at most 999",
    ),
    (
        "filter-largest-half-width-works",
        ["filter", "{msd_csv}", "--half-width", "999", "--out", "{tmp}/o.csv"],
        0,
        r"2001 -> 3 samples",
    ),
]


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_refused_command(case_id, argv, expected_exit, message_regex, hostile):
    check_case(hostile, argv, expected_exit, message_regex)


def test_out_through_a_symbolic_link_to_the_input_is_refused(hostile):
    link = hostile.tmp / "link.csv"
    link.symlink_to(hostile.path("msd_csv"))
    check_case(hostile, [*_FILTER, "--out", str(link)], 2, r"is the input file")


def test_a_read_only_folder_names_the_users_path(hostile, monkeypatch):
    """mkstemp's PermissionError named '.o.csv.abc123.tmp'; the message names the --out path."""

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied", f"{kwargs.get('dir')}/.o.csv.x1y2.tmp")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    res = check_case(
        hostile,
        [*_FILTER, "--out", "{tmp}/o.csv"],
        2,
        r"cannot write '.*/o\.csv': the folder '.*' is not writable \(Permission denied\); "
        r"choose an output in a folder you can write",
    )
    assert ".tmp" not in res.err


@pytest.mark.parametrize("payload_kind", ["string-argument", "quoted-string"])
def test_a_model_file_carrying_code_runs_nothing(hostile, payload_kind):
    """Two code-injection payloads in a model file's expressions, through the CLI: exit 2, the construct named, no file."""
    marker = hostile.tmp / "pwned"
    code = f"__import__('pathlib').Path({str(marker)!r}).touch()"
    expr = f'foo("{code}")' if payload_kind == "string-argument" else repr(code + " or 1")
    toml_string = '"' + expr.replace("\\", "\\\\").replace('"', '\\"') + '"'
    model = hostile.add_file("evil", hostile.tmp / "evil.toml")
    model.write_text(
        'name = "evil"\n[parameters]\nm1 = { value = 1.0 }\n[[joints]]\ndh = { a = 1 }\n'
        f"mass = {toml_string}\n",
        encoding="utf-8",
    )
    check_case(
        hostile,
        ["identify", "{arm_csv}", "--model", "{evil}"],
        2,
        r"evil\.toml, line 6 .*a string literal \(quotes\) is not allowed",
    )
    assert not marker.exists()


def test_simulate_twice_gives_identical_bytes(hostile):
    """No wall-clock time in the data file: the same command writes the same bytes."""
    outs = []
    for k in range(2):
        path = hostile.tmp / f"run{k}.csv"
        argv = ["simulate", "manipulator", "--noise-std", "1e-4", "--seed", "5", "--out", path]
        res = run_cli(argv)
        assert res.code == 0, res.err
        outs.append(path.read_bytes())
    assert outs[0] == outs[1]
    assert b"wall_seconds" not in outs[0]


def test_simulate_msd_twice_gives_identical_bytes(hostile):
    outs = []
    for k in range(2):
        path = hostile.tmp / f"msd{k}.npz"
        res = run_cli(["simulate", "msd", "--snr", "40", "--seed", "3", "--out", str(path)])
        assert res.code == 0, res.err
        outs.append(path.read_bytes())
    assert outs[0] == outs[1]


def test_numpy_warnings_become_one_physid_warning_line(hostile, monkeypatch):
    """Raw RuntimeWarnings (file:line text) never reach stderr; each becomes one clean line."""
    import numpy as np

    import physid.cli.verb_filter as verb

    real = verb.run

    def noisy(args):
        for _ in range(3):
            np.array([1e308]) * 10  # overflow encountered in multiply
        return real(args)

    monkeypatch.setattr(verb, "run", noisy)
    res = check_case(
        hostile,
        [*_FILTER, "--out", "{tmp}/o.csv"],
        0,
        r"physid: warning: numpy: overflow encountered in multiply( \(\d times\))?; some "
        r"intermediate values were infinite or undefined",
    )
    assert res.err.count("physid: warning:") == 1


def test_simulate_a_model_file_twice_gives_identical_bytes(hostile):
    """The generic chain path (``physid simulate MODEL.toml``) keeps time out of the file too."""
    outs = []
    for k in range(2):
        path = hostile.tmp / f"pend{k}.csv"
        argv = ["simulate", str(hostile.path("model_toml")), "--duration", "0.2", "--out", path]
        res = run_cli(argv)
        assert res.code == 0, res.err
        outs.append(path.read_bytes())
    assert outs[0] == outs[1]
