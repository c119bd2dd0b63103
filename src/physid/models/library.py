"""Built-in models: Cedro & Janecki's 4-DOF manipulator, Oueslati et al.'s mass–spring–damper.

`load_model` is the one entry point: a built-in name or the path of a TOML model file.
"""

from __future__ import annotations

import os
import stat
from importlib import resources
from pathlib import Path

from ..errors import InputError, ModelFileError
from .linear_ode import msd_model
from .spec import ChainSpec, parse_model_text, read_model_file

__all__ = [
    "load_model",
    "load_model_file",
    "model_from_spec",
    "manipulator_model",
    "manipulator_spec",
    "BUILTIN_MODELS",
]

#: Names `load_model` accepts besides file paths.
BUILTIN_MODELS = ("manipulator", "msd", "msd-force", "arm6")


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
        ``"manipulator"``, ``"msd"``, ``"arm6"`` (a 6-DOF UR5-like rigid-body arm with friction
        and armature), the path of a ``.toml`` model file (docs/model-files.md), of a URDF
        sidecar TOML (``extends = "robot.urdf"``) or of a ``.urdf`` file.
    **options
        ``"manipulator"`` and chain files: ``kinetic`` ("exact" | "paper"), ``cache`` (bool).
        Rigid-body models (URDF, sidecars, rigid-body chains): ``strict`` (bool: refuse
        physically doubtful inertias instead of warning).
        ``"msd"``: ``mass`` [kg], ``damping`` [N·s/m], ``stiffness`` [N/m], ``input``
        ("normalised" | "force"); ``"msd-force"`` is ``"msd"`` with ``input="force"`` (u = F [N],
        m, c and k estimated). Unknown options raise `InputError`.

    Returns
    -------
    ChainModel or LinearODEModel

    Examples
    --------
    >>> model = load_model("msd")
    >>> model.a_names, model.b_names
    (('theta2', 'theta1'), ('b0',))
    """
    if isinstance(name_or_path, str) and name_or_path == "arm6":
        bad = set(options) - {"strict", "cache"}
        if bad:
            raise InputError(
                f"unknown option(s) {sorted(bad)} for built-in model 'arm6'; allowed: strict, cache."
            )
        with resources.as_file(resources.files("physid.models").joinpath("data")) as folder:
            return load_model_file(Path(folder) / "arm6.toml", strict=options.get("strict", False))
    if isinstance(name_or_path, str) and name_or_path in BUILTIN_MODELS:
        if name_or_path == "manipulator":
            allowed = {"kinetic", "cache"}
            builder = manipulator_model
        elif name_or_path == "msd-force":  # u = F [N]: m, c, k estimated (msd_model docs)
            allowed = {"mass", "damping", "stiffness"}

            def builder(**kw):
                return msd_model(input="force", **kw)
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
            f"name_or_path must be a built-in name {BUILTIN_MODELS} or a path to a .toml or "
            f".urdf model file; got {type(name_or_path).__name__}."
        )
    path = Path(name_or_path)
    _check_regular_file(path)
    if not path.exists():
        raise ModelFileError(
            f"{str(name_or_path)!r} is neither a built-in model {BUILTIN_MODELS} nor an existing "
            f"model file; check the spelling or the path."
        )
    return load_model_file(path, **options)


# ---------------------------------------------------------------------------------------------

_SPECIAL_FILES = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _check_regular_file(path: Path) -> None:
    """Refuse a model path that exists and is a FIFO, device or socket, before opening it.

    Reading one would block (a FIFO waits for a writer) or never end (``/dev/zero``). Folders
    and missing paths are left to the callers' own messages; a symbolic link is judged by its
    target.
    """
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return
    for test, kind in _SPECIAL_FILES:
        if test(mode):
            raise ModelFileError(
                f"{str(path)!r} is {kind}, not a model file; give the path of a .toml or .urdf "
                "model file."
            )


def load_model_file(path, **options):
    """Load a TOML model file (see ``docs/model-files.md``) into a model.

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file.
    **options
        For chains: ``kinetic`` ("exact" | "paper", overrides the file), ``cache`` (bool).
        Linear ODE models take no options.

    Returns
    -------
    ChainModel or LinearODEModel

    Raises
    ------
    ModelFileError
        Any problem in the file, naming its line and the fix.
    """
    strict = options.pop("strict", False)
    _check_regular_file(Path(path))
    spec = read_model_file(path, strict=strict)
    return model_from_spec(spec, strict=strict, **options)


def model_from_spec(spec, *, strict: bool = False, **options):
    """Build a `ChainModel` or `LinearODEModel` from a specification.

    Parameters
    ----------
    spec : ChainSpec or LinearODESpec
        From `read_model_file` / `parse_model_text`.
    strict : bool
        Chains: refuse (instead of warn about) negative masses and inertias.
    **options
        For chains: ``kinetic`` ("exact" | "paper", overrides the spec) and ``cache`` (bool,
        use the on-disk derivation cache). Linear ODE models take none.

    Returns
    -------
    ChainModel or LinearODEModel

    Raises
    ------
    InputError
        An unknown option.
    ModelFileError
        An expression that does not parse, an unknown symbol, a transform that is not rigid.
    """
    from ..errors import InputError
    from .rigid import RigidChain

    if isinstance(spec, RigidChain):
        from .rigid_model import RigidBodyModel

        bad = set(options) - {"kinetic", "cache"}
        if bad:
            raise InputError(
                f"unknown option(s) {sorted(bad)} for rigid-body model {spec.name!r}; allowed: "
                "kinetic, cache, strict (at load)."
            )
        if options.get("kinetic", "exact") != "exact":
            raise InputError(
                f"kinetic={options['kinetic']!r}: rigid-body model {spec.name!r} has only the exact "
                "kinetic energy (the paper's formula is for point masses on revolute joints)."
            )
        return RigidBodyModel(spec)
    if isinstance(spec, ChainSpec):
        from .chain import build_chain_model
        from .spec import check_nominal_values

        check_nominal_values(spec)
        _check_signs(spec, strict)

        allowed = {"kinetic", "cache"}
        bad = set(options) - allowed
        if bad:
            raise InputError(
                f"unknown option(s) {sorted(bad)} for chain model {spec.name!r}; allowed: "
                f"{sorted(allowed)}."
            )
        model = build_chain_model(spec, **options)
        _check_not_singular(model)
        return model
    from .spec_structure import StructureSpec

    if isinstance(spec, StructureSpec):
        from .structure import StructureModel

        if options:
            raise InputError(
                f"structure model {spec.name!r} takes no options; got {sorted(options)}."
            )
        return StructureModel.from_spec(spec)
    from .linear_ode import LinearODEModel

    if options:
        raise InputError(
            f"linear ODE model {spec.name!r} takes no options; got {sorted(options)}. Edit the "
            f"parameter values in the model file instead."
        )
    return LinearODEModel.from_spec(spec)


def _check_signs(spec, strict: bool) -> None:
    """Warn about (``strict``: refuse) a negative mass or rotor inertia at the nominal values."""
    import warnings

    import numpy as np

    from ..errors import PhysidError
    from ..expressions import evaluate_expression
    from .urdf import ModelWarning

    values = {p.name: p.value for p in spec.parameters}
    for k, joint in enumerate(spec.joints):
        for attr, what in (("mass", "mass [kg]"), ("rotor_inertia", "rotor inertia [kg·m²]")):
            text = getattr(joint, attr)
            try:
                v = float(np.asarray(evaluate_expression(text, values)))
            except (PhysidError, TypeError, ValueError):
                continue
            if v < 0:
                where = joint.location(attr) or f"{spec.source} (joints[{k + 1}].{attr})"
                msg = (
                    f"{where}: the {what} of joint {k + 1} is {v:.6g} at the nominal parameter "
                    f"values ({text!r}); a mass or inertia must be >= 0. Check the sign and the "
                    "parameter values."
                )
                if strict:
                    raise ModelFileError(msg)
                warnings.warn(msg, ModelWarning, stacklevel=4)


def _check_not_singular(model) -> None:
    """Refuse a chain whose mass matrix is singular at the nominal parameters (random states)."""
    import numpy as np

    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, (4, model.n_joints))
    M = model.mass_matrix(q)
    for s in range(M.shape[0]):
        ev = np.linalg.eigvalsh(M[s])
        if not np.abs(ev).min() > 1e-12 * max(float(np.abs(ev).max()), 1e-300):
            j = int(np.argmin(np.abs(np.diag(M[s]))))
            raise ModelFileError(
                f"{model.spec.source}: the mass matrix is singular at the nominal parameters "
                f"(eigenvalues {np.round(ev, 9).tolist()} at a random pose): joint {j + 1} moves "
                "no mass or inertia — a zero-length link, a point mass on its own axis, or a "
                "zero mass. Give that link a length or a mass off the axis, or the joint a "
                "rotor_inertia."
            )
