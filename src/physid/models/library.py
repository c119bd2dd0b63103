"""Built-in models: Cedro & Janecki's 4-DOF manipulator, Oueslati et al.'s mass–spring–damper.

`load_model` is the one entry point: a built-in name or the path of a TOML model file.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from ..errors import InputError, ModelFileError
from .linear_ode import msd_model
from .spec import model_from_spec, parse_model_text, read_model_file

__all__ = ["load_model", "manipulator_model", "manipulator_spec", "BUILTIN_MODELS"]

#: Names `load_model` accepts besides file paths.
BUILTIN_MODELS = ("manipulator", "msd")


def manipulator_spec():
    """The specification of the paper's arm (packaged ``models/data/manipulator.toml``).

    Returns
    -------
    ChainSpec
        4 joints, θ = (m1, m2, m3, m4, l1, l2, l3, l4), gravity (0, 0, +9.81) m/s².

    Examples
    --------
    >>> manipulator_spec().parameter_names
    ('m1', 'm2', 'm3', 'm4', 'l1', 'l2', 'l3', 'l4')
    """
    text = (
        resources.files("physid.models")
        .joinpath("data/manipulator.toml")
        .read_text(encoding="utf-8")
    )
    return parse_model_text(text, source="<built-in manipulator.toml>")


def manipulator_model(*, kinetic: str = "exact", cache: bool = True):
    """The 4-DOF manipulator of Cedro & Janecki (section 2).

    T1 = DH(a=0, α=π/2), T2..T4 = DH(a=l_k, α=0); point masses at the link ends; J_k = m_k l_k²/12;
    g = (0, 0, +9.81) m/s²; θ = (m1, m2, m3, m4, l1, l2, l3, l4) = (50, 25, 15, 5 kg; 0.4, 0.8,
    0.6, 0.2 m).

    Parameters
    ----------
    kinetic : {"exact", "paper"}
        "exact" (½ m|v|², the physically correct energy, default) or "paper" (the paper's formula
        without cross terms, to reproduce its numbers).
    cache : bool
        Use the on-disk derivation cache.

    Returns
    -------
    ChainModel

    Examples
    --------
    >>> model = manipulator_model()
    >>> model.n_joints, model.parameters["m2"], model.gravity
    (4, 25.0, (0.0, 0.0, 9.81))
    """
    return model_from_spec(manipulator_spec(), kinetic=kinetic, cache=cache)


def load_model(name_or_path, **options):
    """Load a built-in model or a TOML model file.

    Parameters
    ----------
    name_or_path : str or Path
        ``"manipulator"``, ``"msd"``, or the path of a ``.toml`` model file (docs/model-files.md).
    **options
        ``"manipulator"`` and chain files: ``kinetic`` ("exact" | "paper"), ``cache`` (bool).
        ``"msd"``: ``mass`` [kg], ``damping`` [N·s/m], ``stiffness`` [N/m], ``input``
        ("normalised" | "force"). Unknown options raise `InputError`.

    Returns
    -------
    ChainModel or LinearODEModel

    Examples
    --------
    >>> model = load_model("msd")
    >>> model.a_names, model.b_names
    (('theta2', 'theta1'), ('b0',))
    """
    if isinstance(name_or_path, str) and name_or_path in BUILTIN_MODELS:
        if name_or_path == "manipulator":
            allowed = {"kinetic", "cache"}
            builder = manipulator_model
        else:
            allowed = {"mass", "damping", "stiffness", "input"}
            builder = msd_model
        bad = set(options) - allowed
        if bad:
            raise InputError(
                f"unknown option(s) {sorted(bad)} for built-in model {name_or_path!r}; allowed: "
                f"{sorted(allowed)}."
            )
        return builder(**options)
    if not isinstance(name_or_path, (str, Path)):
        raise InputError(
            f"name_or_path must be a built-in name {BUILTIN_MODELS} or a path to a .toml model "
            f"file; got {type(name_or_path).__name__}."
        )
    path = Path(name_or_path)
    if not path.exists():
        raise ModelFileError(
            f"{str(name_or_path)!r} is neither a built-in model {BUILTIN_MODELS} nor an existing "
            f"model file; check the spelling or the path."
        )
    return model_from_spec(read_model_file(path), **options)
