"""Linear ODE models  Σ_{i=0}^{n} a_i y^(i) = Σ_{i=0}^{m} b_i u^(i),  a_n = 1, m < n.

The mass–spring–damper of Oueslati et al. (eq. 1) is the order-2 case

    ẍ + θ1 ẋ + θ2 x = b0 u,   θ1 = c/m = 2ζω0,   θ2 = k/m = ω0²,

with u the force divided by the mass (b0 = 1, the paper's and physid's recording convention) or
the force itself (b0 = 1/m, the force-input form whose m, c and k are parameters). The
conversions between (m, c, k), (θ1, θ2, b0) and (ω0, ζ) are module functions of
`physid.models.msd`, importable from here too.

Coefficients in physical terms
------------------------------
A coefficient may be an expression of physical parameters (``a = ["k/m", "c/m"]``,
``b = ["1/m"]``). The estimators estimate the coefficients, which enter the equation linearly;
`LinearODEModel.physical_from_coefficients` maps them back to the physical parameters where
those are identifiable, and names the combinations that are when they are not (k/m and c/m
without a force measurement); that map lives in `physid.models.linear_ode_physical`.
"""

from __future__ import annotations

import numpy as np

from .._validate import as_1d, check_finite, parameter_vector
from ..errors import InputError, arg
from .linear_ode_physical import (  # noqa: F401 - re-exported
    PhysicalParameters,
    _evaluate,
    _expression_parameters,
    _Inverse,
    _names_of,
    _physical_from_coefficients,
    expression_unit,
)
from .msd import (
    MSD_DAMPING,
    MSD_MASS,
    MSD_NATURAL_FREQUENCY,
    MSD_STIFFNESS,
    msd_from_physical,
    natural_frequency_damping,
    physical_from_theta,
    theta_from_natural,
)
from .spec_types import LinearODESpec

__all__ = [
    "LinearODEModel",
    "PhysicalParameters",
    "as_linear_ode_model",
    "expression_unit",
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
    expressions : dict
        Coefficient name → expression over physical parameters (``{"theta2": "k/m"}``); empty
        when every coefficient is a parameter itself.
    physical_names : tuple of str
        The physical parameters the expressions use (``("m", "c", "k")``).
    physical_unknown : tuple of str
        The physical parameters to identify (``identify = true``).
    input_unit, output_unit : str
        SI units the model expects of u and y (``""``: not checked); see `check_units`.
    output_offset : str or None
        Name of the parameter o of a measured output y_m = y + o (a sensor bias), or None.
        The equation in the measured output is Σ a_i y_m^(i) = Σ b_j u^(j) + a_0 o.
    recording_map : dict
        The model file's ``[recording]`` channel map (empty if none).
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
        expressions: dict | None = None,
        physical_unknown=None,
        input_unit: str = "",
        output_unit: str = "",
        output_offset: str | None = None,
        recording_map: dict | None = None,
    ):
        a_names = tuple(a_names)
        b_names = tuple(b_names)
        expressions = {str(k): str(v) for k, v in (expressions or {}).items()}
        parameters = dict(parameters)
        bad = [k for k in expressions if k not in a_names + b_names]
        if bad:
            raise InputError(f"expressions given for {bad}, which are not coefficients.")
        physical_names = _expression_parameters(expressions, parameters)
        for coef, text in expressions.items():  # nominal coefficient values from the physics
            parameters[coef] = _evaluate(text, parameters, coef)
        _check_coefficient_names(a_names, b_names, parameters)
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
        for coef, text in expressions.items():  # "k/m" with k [N/m], m [kg]: 1/s^2
            if not self.units.get(coef):
                self.units[coef] = expression_unit(text, self.units)
        self.unknown = tuple(unknown) if unknown is not None else self.coefficient_names
        bad = [u for u in self.unknown if u not in self.parameter_names]
        if bad:
            raise InputError(f"unknown names {bad} are not parameters of {name!r}.")
        self.input_name = input_name
        self.output_name = output_name
        self.description = description
        self.expressions = expressions
        self.physical_names = physical_names
        candidates = physical_names + (
            (output_offset,) if output_offset and output_offset not in physical_names else ()
        )
        if physical_unknown is None:
            physical_unknown = candidates
        self.physical_unknown = tuple(p for p in candidates if p in set(physical_unknown))
        if expressions and unknown is None:
            # a coefficient is estimated when its expression involves a parameter to identify
            self.unknown = tuple(
                c
                for c in self.coefficient_names
                if c not in expressions
                or set(_names_of(expressions[c])) & set(self.physical_unknown)
            )
        self.input_unit = str(input_unit or "")
        self.output_unit = str(output_unit or "")
        if output_offset is not None and output_offset not in self._nominal:
            raise InputError(
                f"output_offset {output_offset!r} is not a parameter of {name!r}; declare it "
                f"(parameters: {list(self.parameter_names)})."
            )
        self.output_offset = output_offset
        self.recording_map = dict(recording_map or {})
        self._inverse = None

    @classmethod
    def from_spec(cls, spec: LinearODESpec) -> LinearODEModel:
        """Build from a parsed TOML specification (coefficients may be expressions)."""
        expressions = dict(getattr(spec, "expressions", ()) or ())
        identify = tuple(p.name for p in spec.parameters if p.identify)
        offset = getattr(spec, "output_offset", None)
        return cls(
            spec.name,
            spec.a,
            spec.b,
            {p.name: p.value for p in spec.parameters},
            units={p.name: p.unit for p in spec.parameters},
            unknown=None if expressions else tuple(n for n in identify if n != offset),
            input_name=spec.input_name,
            output_name=spec.output_name,
            description=spec.description,
            expressions=expressions,
            physical_unknown=identify,
            input_unit=getattr(spec, "input_unit", ""),
            output_unit=getattr(spec, "output_unit", ""),
            output_offset=offset,
            recording_map=dict(getattr(spec, "recording", ()) or ()),
        )

    @property
    def parameters(self) -> dict:
        return dict(self._nominal)

    @property
    def physical_parameters(self) -> dict:
        """Nominal values of the physical parameters the coefficient expressions use."""
        return {k: self._nominal[k] for k in self.physical_names}

    def known_output_offset(self) -> float:
        """The output offset to subtract before a fit [output unit]: the declared offset's
        ``value`` when it is held (``identify = false``), else 0 (none declared, or estimated).
        """
        if self.output_offset is None or self.offset_unknown:
            return 0.0
        return float(self._nominal[self.output_offset])

    @property
    def offset_unknown(self) -> bool:
        """True when the model has an output offset to estimate (``identify = true``)."""
        return self.output_offset is not None and self.output_offset in self.physical_unknown

    # ------------------------------------------------------------------ units
    def check_units(self, recording) -> None:
        """Refuse a recording whose input or output unit contradicts the model.

        Parameters
        ----------
        recording : Recording
            Its ``unit(name)`` of the model's input and output channels; channels without a
            unit, and models without ``input_unit``/``output_unit``, are not checked.

        Raises
        ------
        InputError
            E.g. a force [N] in ``u`` for the built-in ``msd``, whose u is F/m [m/s²]: the
            message names the force-input model and the channel map that fix it.

        Examples
        --------
        >>> from physid.signals import Recording
        >>> rec = Recording([0.0, 1.0], [[1.0, 0.0], [2.0, 0.1]], ["u", "x"], ["N", "m"])
        >>> msd_model(input="force").check_units(rec)  # a force, as that model wants
        """
        from ..units import dimension_name, parse_unit

        try:
            in_name, out_name = self.recording_channels(recording.names)
        except InputError:
            return  # the estimator names the missing channels
        for channel, want, role in (
            (in_name, self.input_unit, "input"),
            (out_name, self.output_unit, "output"),
        ):
            have = recording.unit(channel)
            if not want or not have:
                continue
            try:
                u_have, u_want = parse_unit(have), parse_unit(want)
            except InputError:
                continue
            if u_have.dimension == u_want.dimension:
                continue
            source = dict(recording.metadata.get("channel_map") or {}).get(channel, channel)
            source = source.split("[")[0].strip()
            fix = (
                f"give the {role} in {want}"
                if not self.is_msd
                else (
                    "to estimate the mass too, use the force-input model "
                    "load_model('msd-force'), or divide the force by a "
                    f"known mass in the map: channels={{{channel!r}: '{source}/MASS [{want}]'}}"
                    if want != "N"
                    else "the built-in load_model('msd') takes u = F/m [m/s^2]"
                )
            )
            raise InputError(
                f"channel {channel!r} is in {have} ({dimension_name(u_have.dimension)}), but "
                f"model {self.name!r} takes its {role} {channel} in {want} "
                f"({dimension_name(u_want.dimension)}"
                f"{'; u = F/m, the normalised input of Oueslati et al.' if self.is_msd and want != 'N' else ''}"
                f"); {fix}."
            )

    # ------------------------------------------------------------------ physical parameters
    def physical_from_coefficients(self, coefficients, covariance=None) -> PhysicalParameters:
        """Map estimated coefficients back to the physical parameters of the expressions.

        Solves ``expression_i(p) = coefficient_i`` for the physical parameters to identify
        (the others at their nominal values), exactly where the map is invertible; where it is
        not (fewer independent coefficients than unknowns, e.g. ``a = ["k/m", "c/m"]`` with
        ``b = ["1"]``: u = F/m carries no scale), only the combinations the coefficients are
        are reported, with their values.

        Parameters
        ----------
        coefficients : mapping of str to float
            Estimated coefficients by name (missing ones take their nominal value).
        covariance : array_like, shape (k, k), optional
            Covariance of the estimated coefficients, ordered like ``names`` of
            ``coefficients`` as given (its iteration order); the physical parameters' standard
            errors follow by the delta method, σ_p = sqrt(diag(J⁺ Σ J⁺ᵀ)) with J = ∂c/∂p at
            the solution.

        Returns
        -------
        PhysicalParameters
            ``values``, ``stderr`` (None without ``covariance``), ``identifiable``,
            ``unidentifiable``, ``combinations`` (expression text → value) and ``message``.

        Raises
        ------
        InputError
            An unknown coefficient name, a non-finite value, or a covariance of the wrong shape.

        Examples
        --------
        >>> model = msd_model(input="force")  # θ2 = k/m, θ1 = c/m, b0 = 1/m
        >>> out = model.physical_from_coefficients({"theta2": 25.0, "theta1": 0.2, "b0": 0.5})
        >>> {k: round(v, 12) for k, v in out.values.items()}
        {'m': 2.0, 'c': 0.4, 'k': 50.0}
        >>> msd_model().physical_from_coefficients({"theta2": 25.0}).values
        {}
        """
        return _physical_from_coefficients(self, coefficients, covariance)

    def physical_identifiability(self) -> PhysicalParameters:
        """Which physical parameters the model's coefficients determine (before any data).

        `physical_from_coefficients` at the nominal coefficient values: ``identifiable`` names
        the physical parameters to identify that the estimated coefficients determine,
        ``unidentifiable`` those they do not, ``combinations`` the coefficient expressions that
        are estimated instead, and ``message`` says it in one line.

        Returns
        -------
        PhysicalParameters
            ``values`` are the nominal values (SI) of the identifiable parameters.

        Examples
        --------
        >>> msd_model(input="force").physical_identifiability().identifiable
        ('m', 'c', 'k')
        """
        return self.physical_from_coefficients(
            {c: self._nominal[c] for c in self.coefficient_names if c in self.unknown}
        )

    @property
    def is_msd(self) -> bool:
        """True for the mass–spring–damper form ẍ + θ1 ẋ + θ2 x = b0 u."""
        return self.a_names == ("theta2", "theta1")

    def recording_channels(self, names, units=None) -> tuple[str, str]:
        """(input, output) channel names of this model in a recording with channels ``names``.

        The model's ``input_name`` and ``output_name``; the output falls back to ``x`` then
        ``y`` (the recording convention of docs/architecture.md). When they are missing, the
        error shows the channel map that would fix it, guessed from the columns' names and
        ``units`` (mapping channel → unit; optional).
        """
        candidates = list(dict.fromkeys([self.output_name, "x", "y"]))
        out_name = next((c for c in candidates if c in names), None)
        if self.input_name not in names or out_name is None:
            from .._hints import guess_map, map_hint, unit_kind

            want_out = candidates[0] if out_name is None else out_name
            kinds = {
                self.input_name: (unit_kind(self.input_unit), "force", "acceleration"),
                want_out: (unit_kind(self.output_unit), "length", "angle"),
            }
            guess = guess_map(kinds, names, units)
            raise InputError(
                f"the recording needs an input channel {self.input_name!r} and an output channel "
                f"{' or '.join(repr(c) for c in candidates)}; it has {list(names)}. "
                + map_hint(guess, {c: "COLUMN" for c in kinds if c not in names})
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

    def _repr_html_(self) -> str:
        """A notebook summary: joints (or input → output) and the nominal parameters."""
        from ._display import model_html

        return model_html(self)

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
        values = dict(zip(names, theta.tolist(), strict=True))
        # physical values given: the coefficients follow from the expressions (unless given)
        if isinstance(params, dict) and self.expressions and set(params) & set(self.physical_names):
            for coef, text in self.expressions.items():
                if coef not in params:
                    values[coef] = _evaluate(text, values, coef)
        return values

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


def _check_coefficient_names(a_names: tuple, b_names: tuple, parameters: dict) -> None:
    """Refuse an empty ``a`` or ``b``, an improper model (m ≥ n) and coefficients without values."""
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


# the mass–spring–damper model (its numbers and conversions: physid.models.msd)
# ---------------------------------------------------------------------------------------------


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
        "normalised": u = F/m [m/s²] (b0 = 1, the recording convention; θ1 and θ2 estimated).
        "force": u = F [N], the model "msd-force" with physical parameters m, c, k and
        coefficients θ2 = k/m, θ1 = c/m, b0 = 1/m, all three estimated so that m, c and k follow
        from `LinearODEModel.physical_from_coefficients`; ``mass``, ``damping`` and
        ``stiffness`` are then only nominal values.

    Returns
    -------
    LinearODEModel
        ``a_names = ("theta2", "theta1")``, ``b_names = ("b0",)``; ``unknown =
        ("theta1", "theta2")`` (normalised) or ``("theta2", "theta1", "b0")`` (force).
        ``input_unit`` "m/s^2" or "N" and ``output_unit`` "m" (see `LinearODEModel.check_units`).

    Example
    -------
    >>> model = msd_model()
    >>> round(model.parameters["theta2"], 6), model.parameters["b0"]
    (133.333333, 1.0)
    """
    if input not in ("normalised", "force"):
        raise InputError(f"input must be 'normalised' (u = F/m) or 'force' (u = F); got {input!r}.")
    p = msd_from_physical(mass, damping, stiffness)
    description = (
        f"mass-spring-damper m={mass} kg, c={damping} N·s/m, k={stiffness} N/m, input={input}"
    )
    if input == "force":
        # m ẍ + c ẋ + k x = F: θ2 = k/m, θ1 = c/m, b0 = 1/m, all three estimated, so that m, c
        # and k follow (physical_from_coefficients); the mass is a parameter, not a hidden 3 kg
        return LinearODEModel(
            "msd-force",
            ("theta2", "theta1"),
            ("b0",),
            {"m": float(mass), "c": float(damping), "k": float(stiffness)},
            units={
                "theta1": "1/s",
                "theta2": "1/s^2",
                "b0": "1/kg",
                "m": "kg",
                "c": "N·s/m",
                "k": "N/m",
            },
            input_name="u",
            output_name="x",
            description=description,
            expressions={"theta2": "k/m", "theta1": "c/m", "b0": "1/m"},
            input_unit="N",
            output_unit="m",
        )
    return LinearODEModel(
        "msd",
        ("theta2", "theta1"),
        ("b0",),
        {"theta2": p["theta2"], "theta1": p["theta1"], "b0": 1.0},
        units={"theta1": "1/s", "theta2": "1/s^2", "b0": "1"},
        unknown=("theta1", "theta2"),
        input_name="u",
        output_name="x",
        description=description,
        input_unit="m/s^2",
        output_unit="m",
    )


def as_linear_ode_model(model) -> LinearODEModel:
    """Return ``model`` as a `LinearODEModel`: a name (``"msd"``), a TOML path, or a model.

    Raises `InputError` for anything else (chain models are identified with
    `physid.estimators.input_error`).
    """
    if isinstance(model, str):  # "msd" or a model file, read here (library imports this module)
        if model in ("msd", "msd-force"):
            model = msd_model(input="force" if model == "msd-force" else "normalised")
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
        structure = type(model).__name__ == "StructureModel"  # several outputs: not here
        raise InputError(
            "model must be a linear ODE model: 'msd', a path to a TOML model file of kind "
            f"'linear_ode', or a LinearODEModel; got {type(model).__name__}. "
            + (
                "Structure models (several masses and outputs) are identified with "
                "make('equation-error', model) or make('output-error', model)."
                if structure
                else "Chain models (the manipulator) are identified with "
                "physid.estimators.input_error."
            )
        )
    return model
