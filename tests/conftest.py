"""Shared test configuration: no GUI backend, a fresh model cache per session, and the
hypothesis profiles of the property tests (``ci``: the default, modest; ``fuzz``: ``make fuzz``)."""

from __future__ import annotations

import os

import matplotlib
import pytest
from hypothesis import HealthCheck, settings

matplotlib.use("Agg")

# Property tests (tests/fuzz/, and any @given test) use these profiles. "ci" keeps `make test`
# quick; "fuzz" is `make fuzz` (pytest tests/fuzz --hypothesis-profile=fuzz). No deadline:
# the machine is shared, and time limits belong in benchmarks, not in tests.
settings.register_profile(
    "ci",
    max_examples=50,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
settings.register_profile(
    "fuzz",
    max_examples=20_000,
    deadline=None,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.function_scoped_fixture,
        HealthCheck.data_too_large,
    ],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="session", autouse=True)
def _isolated_cache(tmp_path_factory):
    """Point physid's on-disk derivation cache at a per-session folder."""
    old = os.environ.get("PHYSID_CACHE_DIR")
    os.environ["PHYSID_CACHE_DIR"] = str(tmp_path_factory.mktemp("physid-cache"))
    yield
    if old is None:
        os.environ.pop("PHYSID_CACHE_DIR", None)
    else:
        os.environ["PHYSID_CACHE_DIR"] = old


@pytest.fixture(scope="session")
def axis_example():
    """examples/linear_axis_drive.py as a module (its ``AXIS_TOML``, the prismatic axis with
    mass, viscous and Coulomb friction and a force offset; ``main()`` runs only as a script)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "linear_axis_drive.py"
    spec = importlib.util.spec_from_file_location("axis_example", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    return example


@pytest.fixture
def offset_msd():
    """The MSD ẍ + θ1 ẋ + θ2 x = u (θ1 = 2, θ2 = 100) with an output offset to estimate
    (``[ode] output_offset = "offset"`` in a model file)."""
    from physid.models.linear_ode import LinearODEModel

    return LinearODEModel(
        "msd_offset",
        ("theta2", "theta1"),
        ("b0",),
        {"theta2": 100.0, "theta1": 2.0, "b0": 1.0, "offset": 0.0},
        unknown=("theta1", "theta2"),
        output_offset="offset",
    )


@pytest.fixture(scope="module")
def planar():
    """The planar two-link arm of tests/data/planar2.urdf (revolute joints, gravity in its
    plane): the small rigid-body model of the IDIM and excitation-design tests."""
    import physid
    from _helpers import PLANAR2

    return physid.load_model(PLANAR2)
