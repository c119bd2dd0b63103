"""One IDIM fit over many logs as a map-reduce (`physid.analysis.fleet_joint.run_joint` and
``physid identify --joint --scheduler``): equal to the in-memory fit of the same logs, on every
backend; refusals name the setting.

Kinds of test (docs STYLE.md): equivalence of forms (in-memory `IDIMEstimator.fit` of the logs
as a list == serial map-reduce == Dask LocalCluster == a tcp:// scheduler, estimates to 1e-9
relative) and error paths.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import physid
from physid.analysis.fleet_joint import run_joint
from physid.cli import main
from physid.errors import InputError
from physid.estimators.idim import IDIMEstimator
from physid.simulate.closed_loop import simulate_closed_loop

KP = (3800.0, 40000.0, 10000.0, 500.0)
KD = (159.5, 120.0, 50.0, 2.0)
W0 = 2 * np.pi * np.array([0.2, 0.3, 0.5, 0.7])


def _run(model, duration, phase, seed):
    t = np.arange(0.0, duration, 1e-3)
    ramp = np.clip(t, 0.0, 1.0)[:, None] ** 3
    ref = ramp * (0.8 * np.sin(np.outer(t, W0) + phase) + 0.3 * np.sin(np.outer(t, 2.3 * W0) + 1))
    return simulate_closed_loop(model, kp=KP, kd=KD, reference=ref, t=t, noise_std=1e-4, rng=seed)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    model = physid.load_model("manipulator")
    folder = tmp_path_factory.mktemp("joint")
    recs, paths = [], []
    for k, (duration, phase) in enumerate([(7.0, 0.0), (6.0, 0.7), (6.5, 1.9)]):
        rec = _run(model, duration, phase, seed=k + 1)
        rec = physid.signals.Recording(
            rec.t, rec.select([n for n in rec.names if n[0] in "qt"]),
            [n for n in rec.names if n[0] in "qt"],
        )  # fmt: skip
        path = folder / f"log{k}.npz"
        rec.save(path)
        recs.append(physid.load_recording(path))
        paths.append(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        memory = IDIMEstimator(model, "wls").fit(recs).result_
    return paths, memory


def _values(result):
    return np.array([result.parameters[n] for n in result.names])


@pytest.mark.parametrize("scheduler", ["serial", "local:2"])
def test_joint_map_reduce_equals_the_in_memory_fit(logs, scheduler):
    paths, memory = logs
    result = run_joint("manipulator", paths, method="idim-wls", scheduler=scheduler)
    assert result.names == memory.names and result.n_recordings == 3
    assert (result.decimate, result.cutoff, result.n_rows) == (
        memory.decimate,
        memory.cutoff,
        memory.n_rows,
    )
    np.testing.assert_allclose(_values(result), _values(memory), rtol=1e-9, atol=0)
    se_m = np.array([memory.stderr[n] for n in memory.names])
    se_j = np.array([result.stderr[n] for n in result.names])
    np.testing.assert_allclose(se_j, se_m, rtol=1e-8)
    assert result.success == memory.success and "map-reduce over 3 logs" in result.message


def test_joint_map_reduce_on_a_tcp_scheduler(logs):
    distributed = pytest.importorskip("distributed", reason="needs physid[dask]")
    paths, memory = logs
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        result = run_joint(
            "manipulator", paths, method="idim-wls", scheduler=cluster.scheduler_address
        )
    np.testing.assert_allclose(_values(result), _values(memory), rtol=1e-9, atol=0)


def test_joint_refuses_what_it_cannot_spread(logs):
    paths, _ = logs
    with pytest.raises(InputError, match="idim-ols or idim-wls"):
        run_joint("manipulator", paths, method="idim-iv", scheduler="serial")
    with pytest.raises(InputError, match="takes differentiation"):
        run_joint("manipulator", paths, fit_options={"consistent": True}, scheduler="serial")
    with pytest.raises(InputError, match="at least one log"):
        run_joint("manipulator", [], scheduler="serial")
    with pytest.raises(InputError, match=r"resample=True, but .* reads each log block by block"):
        run_joint("manipulator", paths, load_options={"resample": True}, scheduler="serial")


def test_cli_joint_scheduler_prints_the_fit_over_all_logs(logs, capsys):
    paths, memory = logs
    code = main(["identify", *paths, "--model", "manipulator", "--method", "idim-wls",
                 "--joint", "--scheduler", "serial", "--json"])  # fmt: skip
    out = json.loads(capsys.readouterr().out)
    assert code == (0 if memory.success else 1)
    got = np.array([p["value"] for p in out["base_parameters"]])
    np.testing.assert_allclose(got, _values(memory), rtol=1e-9, atol=0)


def test_cli_joint_scheduler_refusals_name_the_flags(logs, capsys):
    paths, _ = logs
    code = main(["identify", *paths, "--model", "manipulator", "--method", "idim-iv",
                 "--kp", "1,1,1,1", "--kd", "1,1,1,1", "--joint", "--scheduler", "serial"])  # fmt: skip
    assert code == 2 and "--method idim-ols or idim-wls" in capsys.readouterr().err
    code = main(["identify", *paths, "--model", "manipulator", "--method", "idim-ols",
                 "--joint", "--scheduler", "serial", "--stderr", "hac"])  # fmt: skip
    assert code == 2 and "--stderr hac" in capsys.readouterr().err
    code = main(["identify", *paths, "--model", "manipulator", "--scheduler", "serial"])
    assert code == 2 and "add --each" in capsys.readouterr().err


def test_a_bad_log_on_a_cluster_is_one_named_error_not_worker_tracebacks(logs, tmp_path, capfd):
    pytest.importorskip("distributed", reason="needs physid[dask]")
    from physid.errors import ShapeError

    paths, _ = logs
    rec = physid.load_recording(paths[1])
    extra = physid.signals.Recording(
        rec.t, np.column_stack([rec.data, rec.data[:, :1]]), [*rec.names, "q5"]
    )
    bad = tmp_path / "five_joints.npz"
    extra.save(bad)
    with pytest.raises(
        ShapeError, match=r"source 2 \(.*five_joints.npz\) has channel\(s\) \['q5'\]"
    ):
        run_joint("manipulator", [paths[0], str(bad)], method="idim-ols", scheduler="local:2")
    err = capfd.readouterr().err
    assert "Compute Failed" not in err and "Traceback" not in err
