"""identify --save → validate: the chain path of issue 15 (input-error and IDIM results)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from physid.analysis.validation import validate
from physid.cli import main


def _run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def arm6_records(tmp_path_factory):
    d = tmp_path_factory.mktemp("arm6")
    paths = []
    for seed in (1, 2):
        p = d / f"run{seed}.csv"
        assert (
            main(
                [
                    "simulate",
                    "arm6",
                    "--out",
                    str(p),
                    "--duration",
                    "4",
                    "--noise-std",
                    "1e-4",
                    "--seed",
                    str(seed),
                ]
            )
            == 0
        )
        paths.append(p)
    return paths


def test_idim_result_file_validates_on_held_out_run(arm6_records, tmp_path, capsys):
    fit_file = tmp_path / "fit.json"
    code, _, _ = _run(
        [
            "identify",
            str(arm6_records[0]),
            "--model",
            "arm6",
            "--method",
            "idim-ols",
            "--save",
            str(fit_file),
            "--json",
        ],
        capsys,
    )
    assert code == 0
    saved = json.loads(fit_file.read_text())
    train = saved["relative_error"]["overall"]
    code, out, _ = _run(
        ["validate", str(fit_file), str(arm6_records[1]), "--model", "arm6", "--json"], capsys
    )
    assert code == 0
    report = json.loads(out)
    held_out = report["relative_error"]["overall"]
    # another noise realisation of the run: the held-out error is of the training error's size
    assert 0.5 * train < held_out < 2.0 * train < 0.05
    # base parameters define no simulable model: (b) is skipped, not run with nominal values
    assert report["fit_percent"] == {}
    # the base parameters are really used: doubling them must ruin the prediction
    saved["parameters"] = {k: 2 * v for k, v in saved["parameters"].items()}
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(saved))
    from physid import load_recording

    worse = validate(bad, load_recording(arm6_records[1]), model="arm6")
    assert worse.relative_error["overall"] > 0.5


def test_input_error_result_file_validates(tmp_path, capsys):
    train, held = tmp_path / "m.csv", tmp_path / "m2.csv"
    assert main(["simulate", "manipulator", "--out", str(train)]) == 0
    assert (
        main(["simulate", "manipulator", "--out", str(held), "--noise-std", "1e-5", "--seed", "3"])
        == 0
    )
    fit_file = tmp_path / "fit.json"
    code, _, err = _run(
        ["identify", str(train), "--model", "manipulator", "--save", str(fit_file)], capsys
    )
    assert code == 0 and "result written to" in err
    code, out, _ = _run(
        ["validate", str(fit_file), str(held), "--model", "manipulator", "--json"], capsys
    )
    assert code == 0
    report = json.loads(out)
    assert report["relative_error"]["overall"] < 0.02
    fits = np.array(list(report["fit_percent"].values()))
    assert fits.size == 4 and np.all(fits > 99.0)


def test_identify_save_refuses_its_own_recording(arm6_records, capsys):
    code, _, err = _run(
        [
            "identify",
            str(arm6_records[0]),
            "--model",
            "arm6",
            "--method",
            "idim-ols",
            "--save",
            str(arm6_records[0]),
        ],
        capsys,
    )
    assert code == 2
    assert "physid: error:" in err
