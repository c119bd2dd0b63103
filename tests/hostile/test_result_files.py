"""Hostile result files read by ``physid validate`` (`load_result`): damaged, truncated, mistyped,
deeply nested or oversized JSON is refused with the file and the key named — never a traceback,
never a value filled in from the model's nominal ones, never blamed on the held-out data."""

from __future__ import annotations

import json

import pytest

from ._cases import case_ids, check_case

_FIX = r"Write it again with physid\.estimators\.results\.save_result"

CASES = [
    # (case_id, argv, expected_exit, message_regex)
    ("truncated-linear", ["validate", "{lin_trunc}", "{msd_csv}"], 2,
     r"lin_trunc\.json': the result file gives no value for theta2 \(in 'parameters' or "
     r"'known'\); it is truncated.*does not fill in nominal values"),
    ("truncated-chain", ["validate", "{ie_trunc}", "{arm_csv}"], 2,
     r"ie_trunc\.json': the result file gives no value for m3, m4 \(in 'parameters' or 'fixed'\)"),
    ("nan-parameter", ["validate", "{lin_nan}", "{msd_csv}"], 2,
     r"lin_nan\.json': 'parameters\.theta1' is nan in the result file .*damaged or was edited, "
     r"not the data"),
    ("infinity-parameter", ["validate", "{lin_inf}", "{msd_csv}"], 2,
     r"'parameters\.theta2' is inf in the result file"),
    ("1e308-parameter", ["validate", "{lin_big}", "{msd_csv}"], 2,
     r"'parameters\.theta1' = 1e\+308 in the result file is beyond ±1e\+150"),
    ("string-parameter", ["validate", "{lin_str}", "{msd_csv}"], 2,
     r"'parameters\.theta1' must be a number; the file has '0\.1' \(str\)"),
    ("bool-parameter", ["validate", "{lin_bool}", "{msd_csv}"], 2,
     r"'parameters\.theta1' must be a number; the file has True \(bool\)"),
    ("list-for-parameters", ["validate", "{lin_list}", "{msd_csv}"], 2,
     r"is not a physid result file \(no 'parameters' object\)"),
    ("list-for-settings", ["validate", "{lin_settings}", "{msd_csv}"], 2,
     r"'settings' must be an object; the file has \[1\] \(list\)"),
    ("list-for-known", ["validate", "{lin_known}", "{msd_csv}"], 2,
     r"'known' must be an object of name: number; the file has \[1\]"),
    ("string-for-known-value", ["validate", "{lin_knownstr}", "{msd_csv}"], 2,
     r"'known\.b0' must be a number; the file has 'one'"),
    ("number-for-names", ["validate", "{lin_names}", "{msd_csv}"], 2,
     r"'names' must be a list of strings; the file has 3 \(int\)"),
    ("string-stick-threshold", ["validate", "{ie_stick}", "{arm_csv}"], 2,
     r"'stick_threshold' must be \"auto\", a number or null; the file has 'abc'"),
    ("string-half-width", ["validate", "{ie_hw}", "{arm_csv}"], 2,
     r"ie_hw\.json': 'half_width' must be a positive integer or null; the file has 'x'"),
    ("list-for-gains", ["validate", "{ie_gains}", "{arm_csv}"], 2,
     r"'gains' must be an object; the file has \[1, 2\]"),
    ("unknown-model-option", ["validate", "{ie_opts}", "{arm_csv}"], 2,
     r"ie_opts\.json': its 'model_options' \{\"nope\": 1\}: unknown option"),
    ("number-for-model", ["validate", "{lin_model}", "{msd_csv}"], 2,
     r"'model' must be a string; the file has 7 \(int\)"),
    ("recursion-bomb", ["validate", "{deep}", "{msd_csv}"], 2,
     r"cannot read the result file '.*deep\.json': it is nested too deeply\. " + _FIX),
    ("nested-beyond-limit", ["validate", "{nested}", "{msd_csv}"], 2,
     r"key 'extra(\[0\])+' is nested more than 32 levels deep"),
    ("integer-of-5000-digits", ["validate", "{bigint}", "{msd_csv}"], 2,
     r"it holds an integer of thousands of digits"),
    ("truncated-json", ["validate", "{cut}", "{msd_csv}"], 2,
     r"cannot read the result file '.*cut\.json': (Expecting|Unterminated)"),
    ("over-64-MiB", ["validate", "{huge}", "{msd_csv}"], 2,
     r"huge\.json' holds 67\.1 MB, more than the 67\.1 MB a physid result file can reach"),
    ("a-folder", ["validate", "{folder}", "{msd_csv}"], 2, r"is not a regular file"),
    ("not-utf8", ["validate", "{latin1}", "{msd_csv}"], 2,
     r"cannot read the result file '.*latin1\.json': 'utf-8' codec"),
]  # fmt: skip


@pytest.fixture(scope="module")
def fits(tmp_path_factory):
    """A linear (algebraic) and a chain (input-error) result file, fitted once."""
    from ._cases import run_cli

    d = tmp_path_factory.mktemp("fits")
    argv = ["simulate", "msd", "--duration", "2", "--snr", "40", "--seed", "1"]
    assert run_cli([*argv, "--out", str(d / "msd.csv")]).code == 0
    assert run_cli(["estimate", str(d / "msd.csv"), "--save", str(d / "lin.json")]).code == 0
    assert run_cli(["simulate", "manipulator", "--out", str(d / "arm.csv")]).code == 0
    res = run_cli(
        ["identify", str(d / "arm.csv"), "--model", "manipulator", "--method", "input-error",
         "--save", str(d / "ie.json")]
    )  # fmt: skip
    assert res.code == 0, res.err
    return json.loads((d / "lin.json").read_text()), json.loads((d / "ie.json").read_text())


def _edited(base, **changes):
    out = json.loads(json.dumps(base))
    for key, value in changes.items():
        if value is _DROP:
            out.pop(key, None)
        else:
            out[key] = value
    return out


_DROP = object()


def _files(env, fits):
    lin, ie = fits
    lp, ip = lin["parameters"], ie["parameters"]
    docs = {
        "lin_trunc": _edited(lin, parameters={"theta1": lp["theta1"]}),
        "ie_trunc": _edited(ie, parameters={k: v for k, v in ip.items() if k not in ("m3", "m4")}),
        "lin_big": _edited(lin, parameters={**lp, "theta1": 1e308}),
        "lin_str": _edited(lin, parameters={**lp, "theta1": "0.1"}),
        "lin_bool": _edited(lin, parameters={**lp, "theta1": True}),
        "lin_list": _edited(lin, parameters=[1, 2]),
        "lin_settings": _edited(lin, settings=[1]),
        "lin_known": _edited(lin, known=[1]),
        "lin_knownstr": _edited(lin, known={"b0": "one"}),
        "lin_names": _edited(lin, names=3),
        "lin_model": _edited(lin, model=7),
        "ie_stick": _edited(ie, stick_threshold="abc", method="idim-ols"),
        "ie_hw": _edited(ie, half_width="x"),
        "ie_gains": _edited(ie, gains=[1, 2], torque="pd"),
        "ie_opts": _edited(ie, model_options={"nope": 1}),
        "nested": _edited(lin, extra=json.loads("[" * 40 + "]" * 40)),
    }
    for name, doc in docs.items():
        env.add_file(name, env.tmp / f"{name}.json").write_text(json.dumps(doc))
    texts = {  # what json.dumps would not write: NaN, Infinity, a cut file, a bomb
        "lin_nan": json.dumps(_edited(lin, parameters={**lp, "theta1": float("nan")})),
        "lin_inf": json.dumps(_edited(lin, parameters={**lp, "theta2": float("inf")})),
        "deep": '{"parameters": {}, "model": "msd", "x": ' + "[" * 100_000 + "]" * 100_000 + "}",
        "bigint": '{"parameters": {"theta1": ' + "1" * 5000 + '}, "model": "msd"}',
        "cut": json.dumps(lin)[:200],
    }
    for name, text in texts.items():
        env.add_file(name, env.tmp / f"{name}.json").write_text(text)
    huge = env.add_file("huge", env.tmp / "huge.json")
    with open(huge, "wb") as fh:  # sparse: 64 MiB + 1 byte without writing them
        fh.truncate(64 * 2**20 + 1)
    folder = env.add_file("folder", env.tmp / "folder.json")
    folder.mkdir()
    env.add_file("latin1", env.tmp / "latin1.json").write_bytes(b'{"model": "caf\xe9"}')


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_result_file(case_id, argv, expected_exit, message_regex, hostile, fits):
    _files(hostile, fits)
    check_case(hostile, argv, expected_exit, message_regex)


def test_intact_result_files_still_validate(hostile, fits):
    """The checks refuse only what is broken: the files as saved validate as before."""
    lin, ie = fits
    for name, doc, data in (("lin_ok", lin, "{msd_csv}"), ("ie_ok", ie, "{arm_csv}")):
        hostile.add_file(name, hostile.tmp / f"{name}.json").write_text(json.dumps(doc))
        check_case(hostile, ["validate", f"{{{name}}}", data], 0, r"\(a\) inverse model")


def test_load_result_refuses_a_truncated_file_in_the_library(hostile, fits):
    from physid.analysis.validation import load_result
    from physid.errors import DataFileError

    _files(hostile, fits)
    with pytest.raises(DataFileError, match=r"gives no value for m3, m4"):
        load_result(hostile.path("ie_trunc"))
