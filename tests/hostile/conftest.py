"""Fixtures of the hostile-input tables: the session's input files and a per-test `HostileEnv`."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from ._cases import HostileEnv


def _cli_file(path, argv):
    from ._cases import run_cli

    res = run_cli([*argv, "--out", str(path)])
    assert res.code == 0, res.err
    return path


@pytest.fixture(scope="session")
def hostile_sources(tmp_path_factory):
    """Builders of the shared input files, each run at most once per session."""
    root = tmp_path_factory.mktemp("hostile-inputs")

    @functools.cache
    def msd_csv():
        return _cli_file(
            root / "msd.csv", ["simulate", "msd", "--duration", "2", "--snr", "40", "--seed", "1"]
        )

    @functools.cache
    def msd_npz():
        from physid.signals import load_recording, save_recording

        return save_recording(load_recording(msd_csv()), root / "msd.npz")

    @functools.cache
    def arm_csv():
        return _cli_file(root / "arm.csv", ["simulate", "manipulator"])

    @functools.cache
    def short_csv():
        from physid.signals import Recording, save_recording

        t = 1e-3 * np.arange(50)
        rec = Recording(t, np.sin(t)[:, None], ("q1",), ("rad",))
        return save_recording(rec, root / "short.csv")

    @functools.cache
    def model_toml():
        path = root / "pendulum.toml"
        path.write_text(
            'name = "pendulum"\ngravity = [0, -9.81, 0]\n[parameters]\n'
            'm1 = { value = 2.0, unit = "kg" }\nl1 = { value = 0.5, unit = "m" }\n'
            '[[joints]]\ndh = { a = "l1" }\nmass = "m1"\n',
            encoding="utf-8",
        )
        return path

    @functools.cache
    def dir_csv():
        path = root / "dir.csv"
        path.mkdir()
        return path

    return {
        "dir_csv": dir_csv,
        "msd_csv": msd_csv,
        "msd_npz": msd_npz,
        "arm_csv": arm_csv,
        "short_csv": short_csv,
        "model_toml": model_toml,
    }


@pytest.fixture
def hostile(tmp_path, hostile_sources):
    """A `HostileEnv` for one case: ``{tmp}`` is this test's folder."""
    return HostileEnv(tmp=tmp_path, sources=hostile_sources)
