"""Linear ODE models  Σ_{i=0}^{n} a_i y^(i) = Σ_{i=0}^{m} b_i u^(i),  a_n = 1, m < n.

The mass–spring–damper of Oueslati et al. (eq. 1) is the order-2 case

    ẍ + θ1 ẋ + θ2 x = b0 u,   θ1 = c/m = 2ζω0,   θ2 = k/m = ω0²,

with u the force divided by the mass (b0 = 1, the paper's and physid's recording convention) or
the force itself (b0 = 1/m). The conversions between (m, c, k), (θ1, θ2, b0) and (ω0, ζ) live here
as module functions.
"""

from __future__ import annotations

import numpy as np

from .._validate import as_1d, check_finite, check_positive, parameter_vector
from ..errors import InputError, arg
from .spec import LinearODESpec

__all__ = [
    "LinearODEModel",
    "as_linear_ode_model",
    "linear_ode_state_space",
    "normalised_coefficients",
    "msd_model",
    "msd_from_physical",
    "natural_frequency_damping",
    "theta_from_natural",
    "physical_from_theta",
    "MSD_MASS",
    "MSD_DAMPING",
    "MSD_STIFFNESS",
    "MSD_NATURAL_FREQUENCY",
]

#: Oueslati et al., section 4: load mass m = 3 kg, damping c = 0.05 N·s/m, spring k = 400 N/m.
MSD_MASS = 3.0
MSD_DAMPING = 0.05
MSD_STIFFNESS = 400.0
#: Its undamped natural frequency ω0 = √(k/m) [rad/s] (≈ 11.547).
MSD_NATURAL_FREQUENCY = float(np.sqrt(MSD_STIFFNESS / MSD_MASS))


class LinearODEModel:
    """A linear ODE Σ a_i y^(i) = Σ b_i u^(i) with a_n = 1 and m < n, coefficients named.

    Attributes
    ----------
    name : str
    order : int
        n, the order of the output derivative (2 for the MSD).
    input_order : int
        m, the highest input derivative (0 for the MSD).
    a_names : tuple of str, length n
        Parameter names of a_0 … a_{n−1} (for the MSD: ("theta2", "theta1")).
    b_names : tuple of str, length m + 1
        Parameter names of b_0 … b_m (for the MSD: ("b0",)).
    coefficient_names : tuple of str
        ``a_names + b_names``.
    parameter_names : tuple of str
        Every parameter of the model (the coefficients, in that order, for models built here).
    parameters : dict
        name → nominal value (a fresh copy on every access).
    units : dict
        name → unit.
    unknown : tuple of str
        Names estimated by default (``identify = true``).
    input_name, output_name : str
        Recording channel names of u and y ("u", "x" for the MSD).
    """

    def __init__(
        self,
        name: str,
        a_names,
        b_names,
        parameters: dict,
        *,
        units: dict | None = None,
        unknown=None,
        input_name: str = "u",
        output_name: str = "x",
        description: str = "",
    ):
        a_names = tuple(a_names)
        b_names = tuple(b_names)
        if not a_names:
            raise InputError("a_names must name at least a_0 (order n ≥ 1).")
        if not b_names:
            raise InputError("b_names must name at least b_0.")
        if len(b_names) > len(a_names):
            raise InputError(
                f"the input order m = {len(b_names) - 1} must be below the order n = "
                f"{len(a_names)} "
                f"(strictly proper model); got a_names={a_names}, b_names={b_names}."
            )
        missing = [c for c in a_names + b_names if c not in parameters]
        if missing:
            raise InputError(
                f"coefficient(s) {missing} have no value in parameters {sorted(parameters)}."
            )
        self.name = name
        self.order = len(a_names)
        self.input_order = len(b_names) - 1
        self.a_names = a_names
        self.b_names = b_names
        self.coefficient_names = a_names + b_names
        self.parameter_names = tuple(dict.fromkeys(self.coefficient_names + tuple(parameters)))
        self._nominal = {k: float(parameters[k]) for k in self.parameter_names}
        for k, v in self._nominal.items():
            if not np.isfinite(v):
                raise InputError(f"parameter {k!r} must be finite; got {v}.")
        self.units = {k: (units or {}).get(k, "") for k in self.parameter_names}
        self.unknown = tuple(unknown) if unknown is not None else self.coefficient_names
        bad = [u for u in self.unknown if u not in self.parameter_names]
        if bad:
            raise InputError(f"unknown names {bad} are not parameters of {name!r}.")
        self.input_name = input_name
        self.output_name = output_name
        self.description = description

    @classmethod
    def from_spec(cls, spec: LinearODESpec) -> LinearODEModel:
        """Build from a parsed TOML specification."""
        return cls(
            spec.name,
            spec.a,
            spec.b,
            {p.name: p.value for p in spec.parameters},
            units={p.name: p.unit for p in spec.parameters},
            unknown=tuple(p.name for p in spec.parameters if p.identify),
            input_name=spec.input_name,
            output_name=spec.output_name,
            description=spec.description,
        )

    @property
    def parameters(self) -> dict:
        return dict(self._nominal)

    @property
    def is_msd(self) -> bool:
        """True for the mass–spring–damper form ẍ + θ1 ẋ + θ2 x = b0 u."""
        return self.a_names == ("theta2", "theta1")

    def recording_channels(self, names) -> tuple[str, str]:
        """(input, output) channel names of this model in a recording with channels ``names``.

        The model's ``input_name`` and ``output_name``; the output falls back to ``x`` then
        ``y`` (the recording convention of docs/architecture.md).
        """
        candidates = list(dict.fromkeys([self.output_name, "x", "y"]))
        out_name = next((c for c in candidates if c in names), None)
        if self.input_name not in names or out_name is None:
            raise InputError(
                f"the recording needs an input channel {self.input_name!r} and an output channel "
                f"{' or '.join(repr(c) for c in candidates)}; it has {list(names)}."
            )
        return self.input_name, out_name

    def split_coefficients(self, unknown=None, known=None) -> tuple[tuple[str, ...], dict]:
        """Validate which coefficients an estimator estimates and which it is given.

        Parameters
        ----------
        unknown : str or sequence of str, optional
            Coefficients to estimate (default: the model's ``unknown`` less the names given in
            ``known``).
        known : mapping, optional
            Values of other coefficients, overriding the nominal ``parameters``.

        Returns
        -------
        unknown : tuple of str
        values : dict
            Value of every coefficient that is not estimated, and of the others' nominal values.
        """
        names = self.coefficient_names
        known_names = set(known or {})
        if unknown is None:
            # default: the model's unknowns, less those the caller gives values for
            unknown = tuple(u for u in self.unknown if u not in known_names)
            if not unknown:
                raise InputError(
                    f"{arg('known')} gives values for all of the model's unknowns "
                    f"{list(self.unknown)}, so nothing is left to estimate; pass "
                    f"{arg('unknown', '[NAME, ...]', cli='NAME,...')} or drop one from "
                    f"{arg('known')}."
                )
        unknown = (unknown,) if isinstance(unknown, str) else tuple(unknown)
        bad = [u for u in unknown if u not in names]
        if bad:
            raise InputError(
                f"unknown coefficient name(s) {bad}; the model's coefficients are {list(names)}."
            )
        if len(set(unknown)) != len(unknown) or not unknown:
            raise InputError(
                f"unknown must list distinct coefficient names, at least one; got {unknown}."
            )
        known = dict(known or {})
        bad = [k for k in known if k not in names]
        if bad:
            raise InputError(
                f"known value(s) given for {bad}, which are not coefficients of the model; "
                f"its coefficients are {list(names)}."
            )
        both = [k for k in known if k in unknown]
        if both:
            raise InputError(
                f"{both} cannot be both unknown and known; remove them from one of the two."
            )
        values = {k: v for k, v in self._nominal.items() if k in names}
        for k, v in known.items():
            try:
                values[k] = float(v)
            except (TypeError, ValueError):
                raise InputError(f"known[{k!r}] must be a number; got {v!r}.") from None
        return unknown, values

    def __repr__(self) -> str:
        return (
            f"LinearODEModel(name={self.name!r}, order={self.order}, "
            f"input_order={self.input_order}, "
            f"parameters={self.parameters})"
        )

    def parameter_values(self, params=None) -> dict:
        """Nominal values overridden by ``params`` (dict, or array like `parameter_names`)."""
        names = list(self.parameter_names)
        nominal = [self._nominal[k] for k in names]
        theta = parameter_vector(params, names, nominal, model=self.name)
        return dict(zip(names, theta.tolist(), strict=True))

    def coefficients(self, params=None) -> tuple[np.ndarray, np.ndarray]:
        """(a, b): a of shape (n + 1,) with a[n] = 1 (ascending powers), b of shape (m + 1,)."""
        v = self.parameter_values(params)
        a = np.array([v[k] for k in self.a_names] + [1.0])
        b = np.array([v[k] for k in self.b_names])
        return a, b

    def state_space(self, params=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Controllable canonical form (A, B, C, D) of G(s) = Σ b_i s^i / Σ a_i s^i, as 2-D
        arrays (n, n), (n, 1), (1, n), (1, 1); see `linear_ode_state_space`.

        State z = (w, ẇ, …, w^(n−1)) with w^(n) + Σ a_i w^(i) = u, output y = Σ b_i w^(i):
        A = companion matrix (last row −a_0 … −a_{n−1}), B = e_n, C = (b_0 … b_m, 0 …), D = 0
        (m < n). For the MSD with b0 ≠ 1 the first state is x / b0, not x.
        """
        A, B, C, D = linear_ode_state_space(*self.coefficients(params))
        return A, B[:, None], C[None, :], np.array([[D]])


# ---------------------------------------------------------------------------------------------
# coefficients and their state-space realisation
def normalised_coefficients(a, b, where: str) -> tuple[np.ndarray, np.ndarray]:
    """Validate ``(a, b)`` (ascending derivative order) and scale them so that ``a[n] = 1``."""
    a = as_1d(a, f"{where}: denominator coefficients a")
    b = as_1d(b, f"{where}: numerator coefficients b")
    check_finite(a[:, None], f"{where}: a")
    check_finite(b[:, None], f"{where}: b")
    if a.size < 2:
        raise InputError(
            f"{where}: a must hold a_0 .. a_n with order n >= 1 (ascending derivative order); "
            f"got {a.tolist()}."
        )
    if a[-1] == 0:
        raise InputError(
            f"{where}: the leading coefficient a_n (of the highest derivative, last entry) is 0; "
            f"got a = {a.tolist()}. Drop trailing zeros or fix the order."
        )
    if b.size > a.size:
        raise InputError(
            f"{where}: the input order m = {b.size - 1} exceeds the model order n = "
            f"{a.size - 1}; the "
            "model is improper (it would differentiate the input). Give b with at most n + 1 "
            "entries."
        )
    lead = a[-1]
    return a / lead, b / lead


def linear_ode_state_space(a, b) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Controllable canonical realisation of ``Σ_i a_i y^(i) = Σ_j b_j u^(j)``.

    Parameters
    ----------
    a : array_like, shape (n + 1,)
        Denominator coefficients a_0 .. a_n in ascending derivative order (a_n ≠ 0).
    b : array_like, shape (m + 1,), m <= n
        Numerator coefficients b_0 .. b_m in ascending derivative order.

    Returns
    -------
    A (n, n), B (n,), C (n,), D (float)
        ``ż = A z + B u``, ``y = C z + D u`` with ``z = (w, ẇ, …, w^(n−1))`` where
        ``Σ a_i w^(i) = u`` and ``y = Σ b_j w^(j)``.

    Examples
    --------
    >>> A, B, C, D = linear_ode_state_space([400 / 3, 0.05 / 3, 1.0], [1.0])  # the paper's MSD
    >>> A.round(4).tolist(), B.tolist(), C.tolist(), D
    ([[0.0, 1.0], [-133.3333, -0.0167]], [0.0, 1.0], [1.0, 0.0], 0.0)
    """
    a, b = normalised_coefficients(a, b, "linear_ode_state_space")
    n = a.size - 1
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1, :] = -a[:-1]  # w^(n) = u − Σ_{i<n} a_i w^(i)
    B = np.zeros(n)
    B[-1] = 1.0
    bb = np.zeros(n + 1)
    bb[: b.size] = b
    D = float(bb[n])
    C = bb[:n] - D * a[:n]  # y = Σ_{j<n} (b_j − b_n a_j) w^(j) + b_n u
    return A, B, C, D


# ---------------------------------------------------------------------------------------------
# the mass–spring–damper
# ---------------------------------------------------------------------------------------------


def msd_from_physical(mass, damping, stiffness) -> dict:
    """(m [kg], c [N·s/m], k [N/m]) → {"theta1": c/m [1/s], "theta2": k/m [1/s²], "b0": 1/m [1/kg]}.

    b0 = 1/m is the gain from force u = F; with the normalised input u = F/m use b0 = 1.

    Parameters
    ----------
    mass : float [kg]
        m > 0.
    damping : float [N·s/m]
        c >= 0.
    stiffness : float [N/m]
        k > 0.

    Returns
    -------
    dict
        ``theta1`` [1/s], ``theta2`` [1/s²], ``b0`` [1/kg].

    Examples
    --------
    >>> msd_from_physical(3.0, 0.05, 400.0)["theta2"]   # doctest: +ELLIPSIS
    133.33...
    """
    m = check_positive(mass, "mass")
    c = check_positive(damping, "damping", allow_zero=True)
    k = check_positive(stiffness, "stiffness")
    return {"theta1": c / m, "theta2": k / m, "b0": 1.0 / m}


def natural_frequency_damping(theta1, theta2):
    """(θ1, θ2) → (ω0 = √θ2 [rad/s], ζ = θ1 / (2√θ2)); vectorised, NaN where θ2 ≤ 0.

    Parameters
    ----------
    theta1 : float or array_like [1/s]
        θ1 = c/m.
    theta2 : float or array_like [1/s²]
        θ2 = k/m.

    Returns
    -------
    (omega0, zeta) : tuple of float or ndarray
        Natural frequency [rad/s] and damping ratio, shaped like the inputs.
    """
    t1 = np.asarray(theta1, dtype=float)
    t2 = np.asarray(theta2, dtype=float)
    ok = t2 > 0
    omega0 = np.where(ok, np.sqrt(np.where(ok, t2, 1.0)), np.nan)
    zeta = np.where(ok, t1 / (2.0 * np.where(ok, omega0, 1.0)), np.nan)
    if omega0.ndim == 0:
        return float(omega0), float(zeta)
    return omega0, zeta


def theta_from_natural(omega0, zeta):
    """(ω0 [rad/s], ζ) → (θ1 = 2ζω0 [1/s], θ2 = ω0² [1/s²]); vectorised.

    Parameters
    ----------
    omega0 : float or array_like [rad/s]
        Natural frequency.
    zeta : float or array_like
        Damping ratio.

    Returns
    -------
    (theta1, theta2) : tuple of float or ndarray
        θ1 [1/s] and θ2 [1/s²], shaped like the inputs.
    """
    w = np.asarray(omega0, dtype=float)
    z = np.asarray(zeta, dtype=float)
    t1, t2 = 2.0 * z * w, w * w
    if t1.ndim == 0:
        return float(t1), float(t2)
    return t1, t2


def physical_from_theta(theta1, theta2, mass) -> dict:
    """(θ1, θ2, m) → {"mass": m, "damping": c = θ1 m [N·s/m], "stiffness": k = θ2 m [N/m]}.

    Parameters
    ----------
    theta1 : float [1/s]
        θ1 = c/m.
    theta2 : float [1/s²]
        θ2 = k/m.
    mass : float [kg]
        m > 0.

    Returns
    -------
    dict
        ``mass`` [kg], ``damping`` [N·s/m], ``stiffness`` [N/m].
    """
    m = check_positive(mass, "mass")
    return {"mass": m, "damping": float(theta1) * m, "stiffness": float(theta2) * m}


def msd_model(
    mass: float = MSD_MASS,
    damping: float = MSD_DAMPING,
    stiffness: float = MSD_STIFFNESS,
    input: str = "normalised",
) -> LinearODEModel:  # noqa: A002 - the documented keyword
    """The mass–spring–damper ẍ + θ1 ẋ + θ2 x = b0 u of Oueslati et al. (eq. 1).

    Parameters
    ----------
    mass, damping, stiffness : float
        m [kg], c [N·s/m], k [N/m]; defaults are the paper's 3 kg, 0.05 N·s/m, 400 N/m.
    input : {"normalised", "force"}
        "normalised": u = F/m [m/s²] (b0 = 1, the recording convention); "force": u = F [N]
        (b0 = 1/m).

    Returns
    -------
    LinearODEModel
        ``a_names = ("theta2", "theta1")``, ``b_names = ("b0",)``,
        ``unknown = ("theta1", "theta2")``.

    Example
    -------
    >>> model = msd_model()
    >>> round(model.parameters["theta2"], 6), model.parameters["b0"]
    (133.333333, 1.0)
    """
    if input not in ("normalised", "force"):
        raise InputError(f"input must be 'normalised' (u = F/m) or 'force' (u = F); got {input!r}.")
    p = msd_from_physical(mass, damping, stiffness)
    b0 = 1.0 if input == "normalised" else p["b0"]
    return LinearODEModel(
        "msd",
        ("theta2", "theta1"),
        ("b0",),
        {"theta2": p["theta2"], "theta1": p["theta1"], "b0": b0},
        units={"theta1": "1/s", "theta2": "1/s^2", "b0": "1" if input == "normalised" else "1/kg"},
        unknown=("theta1", "theta2"),
        input_name="u",
        output_name="x",
        description=f"mass-spring-damper m={mass} kg, c={damping} N·s/m, k={stiffness} N/m, "
        f"input={input}",
    )


def as_linear_ode_model(model) -> LinearODEModel:
    """Return ``model`` as a `LinearODEModel`: a name (``"msd"``), a TOML path, or a model.

    Raises `InputError` for anything else (chain models are identified with
    `physid.estimators.input_error`).
    """
    if isinstance(model, str):  # "msd" or a model file, read here (library imports this module)
        if model == "msd":
            model = msd_model()
        else:
            from pathlib import Path

            from .spec import read_model_file

            if not Path(model).exists():
                raise InputError(
                    f"model {model!r} is neither 'msd' nor an existing model file; check the "
                    "spelling or the path."
                )
            spec = read_model_file(model)
            if isinstance(spec, LinearODESpec):
                model = LinearODEModel.from_spec(spec)
    if not isinstance(model, LinearODEModel):
        raise InputError(
            "model must be a linear ODE model: 'msd', a path to a TOML model file of kind "
            f"'linear_ode', or a LinearODEModel; got {type(model).__name__}. Chain models (the "
            "manipulator) are identified with physid.estimators.input_error."
        )
    return model
