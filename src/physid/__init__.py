"""physid: identify physical parameters of mechanical systems from measured signals.

The top-level API is deliberately small (see ``docs/architecture.md``)::

    import physid
    model = physid.load_model("manipulator")      # or "msd", or a path to a TOML model file
    rec = physid.load_recording("data.csv")       # CSV / NPZ / MAT / HDF5 -> Recording

Everything else lives in the stage subpackages: `physid.models`, `physid.signals`,
`physid.filters`, `physid.simulate`, `physid.estimators`, `physid.analysis`,
`physid.experiments`, `physid.report`.
"""

from __future__ import annotations

from .errors import (
    DataFileError,
    EstimationError,
    IdentifiabilityError,
    InputError,
    ModelFileError,
    PhysidError,
    SamplingError,
    ShapeError,
    SimulationError,
)

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "load_model",
    "load_recording",
    "Recording",
    "PhysidError",
    "InputError",
    "ShapeError",
    "SamplingError",
    "DataFileError",
    "ModelFileError",
    "IdentifiabilityError",
    "EstimationError",
    "SimulationError",
]


def load_model(name_or_path, **options):
    """Load a built-in model by name (``"manipulator"``, ``"msd"``) or a TOML model file.

    Parameters
    ----------
    name_or_path : str or path
        A built-in name or the path of a model file.
    **options
        Passed on to `physid.models.load_model` (see there).

    Returns
    -------
    ChainModel or LinearODEModel
        The model, with its nominal parameters.
    """
    from .models import load_model as _load_model

    return _load_model(name_or_path, **options)


def load_recording(path, channels=None, **options):
    """Read a recording from CSV, NPZ, MATLAB ``.mat`` or HDF5, in SI units.

    Parameters
    ----------
    path : str or path
        The file.
    channels : mapping of str to str, optional
        The channel map (``{"t": "time", "q1": "qm", "tau1": "gtau*vir"}``).
    **options
        Passed on to `physid.signals.load_recording` (``resample``, ``decimal``,
        ``delimiter``, ``uniform_rtol``; see there).

    Returns
    -------
    Recording
        Time, named channels (SI units), metadata.
    """
    from .signals import load_recording as _load_recording

    return _load_recording(path, channels, **options)


def __getattr__(name):
    # `Recording` is imported on first use, so that `import physid` (and `physid --version`,
    # `physid --help`) loads no numpy: see docs/architecture.md, "Start-up time".
    if name == "Recording":
        from .signals.recording import Recording

        return Recording
    raise AttributeError(f"module 'physid' has no attribute {name!r}")
