"""Helpers shared by the linear-ODE estimators' results (algebraic, recursive).

Units and derived quantities of a linear ODE's coefficients, and the model's prediction on a
recording (open-loop simulation from the recording's input, with the initial state fitted by least
squares, as MATLAB's ``compare`` does with ``InitialCondition = 'estimate'``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping

import numpy as np

from ..models.linear_ode import LinearODEModel, as_linear_ode_model, natural_frequency_damping

#: Units of the derived quantities.
DERIVED_UNITS = {
    "natural_frequency": "rad/s",
    "damping_ratio": "1",
    "mass": "kg",
    "damping": "N*s/m",
    "stiffness": "N/m",
}


def _power(unit: str, k: int) -> str:
    if k == 0:
        return unit or "1"
    tail = "1/s" if k == 1 else f"1/s^{k}"
    return tail if not unit or unit == "1" else f"{unit}/s^{k}" if k > 1 else f"{unit}/s"


def coefficient_units(model: LinearODEModel, names) -> dict[str, str]:
    """Unit of each coefficient in ``names``: the model file's, else ``a_i``: ``1/s^(n−i)``.

    ``b_j`` without a declared unit is ``[y]/([u]·s^(n−j))``, written with ``y`` and ``u`` when the
    channel units are not known.
    """
    n = model.order
    out = {}
    for name in names:
        unit = model.units.get(name, "")
        if not unit:
            if name in model.a_names:
                unit = _power("", n - list(model.a_names).index(name))
            elif name in model.b_names:
                k = n - list(model.b_names).index(name)
                unit = _gain_unit(model, k) or f"{model.output_name}/({model.input_name}*s^{k})"
        out[name] = unit
    return out


def _gain_unit(model: LinearODEModel, k: int) -> str:
    """``[y]/([u]·s^k)`` in SI from the model's ``output_unit`` and ``input_unit`` ("" if unknown)."""
    from ..errors import InputError
    from ..units import _canonical, parse_unit

    if not model.output_unit or not model.input_unit:
        return ""
    try:
        y, u = parse_unit(model.output_unit).dimension, parse_unit(model.input_unit).dimension
    except InputError:
        return ""
    # [b_j] = [y]/([u]·s^k): the time exponent falls by k (b0 of an m/N model is 1/kg, not s^4/kg)
    dim = tuple(a - b - (k if i == 2 else 0) for i, (a, b) in enumerate(zip(y, u, strict=True)))
    return _canonical(dim) or "1"


#: Names of the force-input MSD's physical parameters in ``derived`` (the documented ones).
_MSD_FORCE_NAMES = {"m": "mass", "c": "damping", "k": "stiffness"}
_MSD_FORCE_EXPRESSIONS = {"theta2": "k/m", "theta1": "c/m", "b0": "1/m"}


def derived_with_stderr(
    model: LinearODEModel,
    values: Mapping[str, float],
    fitted,
    covariance=None,
    *,
    with_stderr: bool = True,
):
    """Derived quantities, their delta-method standard errors and the physical parameters.

    The derived quantities are `derived_quantities` (for the MSD: natural frequency, damping
    ratio) and, for a model whose coefficients are expressions of physical parameters, those
    parameters where the coefficients determine them (`LinearODEModel.physical_from_coefficients`;
    for the built-in ``msd-force`` named ``mass``, ``damping``, ``stiffness``). Their standard
    errors follow from the final coefficient covariance by the delta method, ``Σ_d = J Σ_c Jᵀ``
    with ``J`` the Jacobian of the map coefficients → derived at the estimate (analytic for
    ω0 = √θ2 and ζ = θ1/(2√θ2); for the physical parameters ``J = (∂c/∂p)⁺``, derived
    symbolically); known coefficients count as exact.

    Parameters
    ----------
    model : LinearODEModel
    values : mapping
        Every coefficient's value (fitted and known), SI.
    fitted : sequence of str
        The fitted names, the order of ``covariance``'s rows (an output offset among them is
        ignored: no derived quantity depends on it).
    covariance : array_like (len(fitted), len(fitted)), optional
        The final coefficients' covariance (SI); None when the estimator withholds it.
    with_stderr : bool
        False: no standard errors (``derived_stderr`` None) even with a covariance.

    Returns
    -------
    derived : dict
        name -> value.
    derived_stderr : dict or None
        name -> standard error of each derived quantity; None without a covariance.
    units : dict
        name -> unit of each derived quantity (a physical parameter's declared unit).
    physical : dict or None
        `PhysicalParameters.to_dict` of the physical parameters (values, stderr, identifiable,
        unidentifiable, combinations, message); None for a model without coefficient
        expressions.
    """
    fitted = list(fitted)
    derived = derived_quantities(model, values, fitted)
    units = {k: DERIVED_UNITS[k] for k in derived}
    names = list(model.coefficient_names)
    cov = None
    if covariance is not None and with_stderr:
        c = np.asarray(covariance, dtype=float)
        cov = np.zeros((len(names), len(names)))  # known coefficients: exact
        idx = [(i, names.index(f)) for i, f in enumerate(fitted) if f in names]
        for i, a in idx:
            for j, b in idx:
                cov[a, b] = c[i, j]
        if not np.all(np.isfinite(cov)):
            cov = None
    stderr: dict[str, float] = {}
    if cov is not None and "natural_frequency" in derived:
        t1, t2 = names.index("theta1"), names.index("theta2")
        th1, th2 = float(values["theta1"]), float(values["theta2"])
        w = np.sqrt(th2)
        jac = np.zeros((2, len(names)))
        jac[0, t2] = 0.5 / w  # ω0 = √θ2
        jac[1, t1] = 0.5 / w  # ζ = θ1 / (2√θ2)
        jac[1, t2] = -0.25 * th1 / th2**1.5
        var = np.einsum("ij,jk,ik->i", jac, cov, jac)
        stderr["natural_frequency"], stderr["damping_ratio"] = np.sqrt(np.clip(var, 0, None))
    if cov is not None and "mass" in derived and not model.expressions:
        # m = 1/b0, c = θ1/b0, k = θ2/b0 (derived_quantities' rule for a fitted b0)
        t1, t2, tb = names.index("theta1"), names.index("theta2"), names.index("b0")
        th1, th2, b0 = float(values["theta1"]), float(values["theta2"]), float(values["b0"])
        jac = np.zeros((3, len(names)))
        jac[0, tb] = -1.0 / b0**2
        jac[1, t1], jac[1, tb] = 1.0 / b0, -th1 / b0**2
        jac[2, t2], jac[2, tb] = 1.0 / b0, -th2 / b0**2
        var = np.einsum("ij,jk,ik->i", jac, cov, jac)
        for name, v in zip(("mass", "damping", "stiffness"), var, strict=True):
            stderr[name] = float(np.sqrt(max(v, 0.0)))
    physical = None
    if model.expressions:
        for name in ("mass", "damping", "stiffness"):  # the 1/b0 rule is the expressions' job
            derived.pop(name, None)
            units.pop(name, None)
        aliases = (
            _MSD_FORCE_NAMES if model.is_msd and model.expressions == _MSD_FORCE_EXPRESSIONS else {}
        )
        coefs = {c: float(values[c]) for c in names if c in values}
        full = cov
        if cov is not None and len(coefs) != len(names):
            keep = [names.index(c) for c in coefs]
            full = cov[np.ix_(keep, keep)]
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a degenerate estimate (b0 = 0): no values, no noise
            out = model.physical_from_coefficients(coefs, covariance=full)
        physical = out.to_dict()
        # the force-input MSD's mass is 1/b0: as for the built-in rule, only for b0 > 0 (a
        # negative mass is no physical answer; the coefficients stay reported)
        b0 = values.get("b0")
        physical_ok = not aliases or (b0 is not None and np.isfinite(b0) and b0 > 0)
        for p, v in out.values.items():
            name = aliases.get(p, p)
            if not physical_ok or not np.isfinite(v):
                continue
            if name in fitted or name in names or name in derived:
                continue  # a name the result already uses
            derived[name] = float(v)
            units[name] = DERIVED_UNITS.get(name) or model.units.get(p, "")
            if out.stderr is not None:
                stderr[name] = float(out.stderr[p])
    if cov is None:
        return derived, None, units, physical
    return derived, {k: float(stderr.get(k, np.nan)) for k in derived}, units, physical


def physical_statement(physical) -> str:
    """The identifiability sentence of ``physical`` (a `derived_with_stderr` output) for a
    result's message: non-empty only when physical parameters to identify are not determined."""
    if not physical or not physical.get("unidentifiable"):
        return ""
    return str(physical.get("message", ""))


def derived_quantities(model: LinearODEModel, values: Mapping[str, float], fitted) -> dict:
    """Natural frequency, damping ratio (and m, c, k with a force input) of an MSD-form model.

    Parameters
    ----------
    model : LinearODEModel
    values : mapping
        Every coefficient's value (fitted and known).
    fitted : sequence of str
        The fitted names (m, c, k are derived only when ``b0`` was fitted or is ``1/m`` by unit).

    Returns
    -------
    dict
        Empty for models that are not of the MSD form ``ẍ + θ1 ẋ + θ2 x = b0 u``.
    """
    if not model.is_msd:
        return {}
    th1, th2 = values.get("theta1"), values.get("theta2")
    if th1 is None or th2 is None:
        return {}
    omega0, zeta = natural_frequency_damping(float(th1), float(th2))
    out = {"natural_frequency": float(omega0), "damping_ratio": float(zeta)}
    b0 = values.get("b0")
    force_input = "b0" in fitted or model.units.get("b0", "") in ("1/kg", "kg^-1")
    if force_input and b0 is not None and np.isfinite(b0) and b0 > 0:
        m = 1.0 / float(b0)
        out.update({"mass": m, "damping": float(th1) * m, "stiffness": float(th2) * m})
    return out


def simulate_prediction(
    model: LinearODEModel, values: Mapping[str, float], t, u, y=None
) -> tuple[np.ndarray, np.ndarray]:
    """Open-loop output of the model with coefficient ``values`` driven by ``u``.

    With the measured ``y`` given, the initial output derivatives are fitted by least squares
    (the free responses from each unit initial state are linear in it), so a held-out record that
    does not start at rest is compared fairly.

    Returns
    -------
    y_hat : ndarray, shape (n_samples,)
        NaN when the identified model cannot be simulated (unstable beyond overflow).
    x0 : ndarray, shape (order,)
        The initial output derivatives used.
    """
    from ..simulate.linear import simulate_linear_ode

    params = {k: float(v) for k, v in values.items() if k in model.parameter_names}
    t = np.asarray(t, dtype=float)
    n = model.order
    x0 = np.zeros(n)
    offset = getattr(model, "output_offset", None)
    # measured y_m = y + o: the estimate, or the value of a held offset
    o = float(values[offset]) if offset in values else model.known_output_offset()
    try:
        with np.errstate(all="ignore"):
            y_hat = np.asarray(simulate_linear_ode(model, t, input=u, params=params)["x"], float)
            y_hat = y_hat + o
            if y is not None and np.all(np.isfinite(y_hat)):
                free = np.column_stack(
                    [
                        simulate_linear_ode(model, t, input=None, x0=np.eye(n)[k], params=params)[
                            "x"
                        ]
                        for k in range(n)
                    ]
                )
                if np.all(np.isfinite(free)):
                    x0 = np.linalg.lstsq(free, np.asarray(y, float) - y_hat, rcond=None)[0]
                    y_hat = y_hat + free @ x0
    except Exception:  # an unstable or degenerate identified model: no prediction
        return np.full(t.size, np.nan), x0
    return y_hat, x0


def predict_recording(model: LinearODEModel, values: Mapping[str, float], recording):
    """`Recording` with the model's input channel and the predicted output channel."""
    from ..signals.recording import Recording

    in_name, out_name = model.recording_channels(recording.names)
    u = np.asarray(recording[in_name], dtype=float)
    y = np.asarray(recording[out_name], dtype=float)
    y_hat, x0 = simulate_prediction(model, values, recording.t, u, y)
    return Recording(
        np.asarray(recording.t, dtype=float),
        np.column_stack([u, y_hat]),
        [in_name, out_name],
        metadata={"prediction": "open-loop simulation", "initial_state": x0.tolist()},
    )


def check_distinct_channels(input_name: str, output_name: str) -> None:
    """Refuse a model whose input and output are the same recording channel."""
    from ..errors import InputError

    if input_name == output_name:
        raise InputError(
            f"the model's input and output are the same channel {input_name!r}, so the record "
            "cannot excite anything (every linear ODE with b = a fits it); give the input and "
            "the output their own channels (input = ..., output = ... under [ode])."
        )


def check_distinct_signals(u, y) -> None:
    """Refuse an input that is (numerically) a multiple of the output: no information."""

    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    u = u - u.mean()  # constant records are the excitation checks' business
    y = y - y.mean()
    nu, ny = float(np.linalg.norm(u)), float(np.linalg.norm(y))
    refuse_same_signal(nu, ny, float(u @ y), u.size, float(np.abs(u).max(initial=0.0)))


def refuse_same_signal(nu: float, ny: float, uy: float, n: int, u_max: float) -> None:
    """The test of `check_distinct_signals` from the centred input's and output's norms
    ``nu``, ``ny``, their product ``uy``, the count ``n`` and the input's largest magnitude
    ``u_max`` (the streamed fit has these as sums): refuse ``|cos| > 1 − 1e-12``."""
    from ..errors import EstimationError

    if nu <= 1e-12 * math.sqrt(n) * u_max or ny == 0.0:
        return
    cos = abs(uy) / (nu * ny)
    if cos > 1.0 - 1e-12:
        raise EstimationError(
            "the input and the output are the same signal up to a factor (|cos| = "
            f"{cos:.15f}); the recording's input channel is probably mapped to the output "
            "column. A linear ODE driven by its own output is not excited: check the channel "
            "names (the model's input and output, the channel map)."
        )


def check_known_finite(known) -> None:
    """Refuse known coefficient values that are not finite numbers, naming them."""
    from ..errors import InputError, arg

    bad = {}
    for name, value in dict(known or {}).items():
        try:
            v = float(value)
        except (TypeError, ValueError):
            continue  # split_coefficients names non-numbers
        if not np.isfinite(v):
            bad[name] = v
    if bad:
        shown = ", ".join(f"{k} = {v}" for k, v in bad.items())
        first = sorted(bad)[0]
        fix = "{" + repr(first) + ": VALUE}"
        raise InputError(
            f"{arg('known')} values must be finite numbers; got {shown}. A known "
            "coefficient is held at its value in every equation, so NaN or inf makes every "
            f"estimate NaN: give its value ({arg('known', fix, cli=first + '=VALUE')}) "
            f"or estimate it (leave it out of {arg('known')})."
        )


class LinearODEResultMixin:
    """What the algebraic and RLS results share: the history, all coefficients and `predict`.

    Needs the dataclass fields ``estimates``, ``known``, ``parameters``, ``model`` and
    ``model_name``.
    """

    @property
    def history(self) -> np.ndarray:
        """Per-sample estimates, shape (n_samples, len(names)) (the ``estimates`` array)."""
        return self.estimates

    @property
    def coefficients(self) -> dict[str, float]:
        """Every coefficient's value: the known ones and the fitted ones."""
        return {**self.known, **dict(self.parameters)}

    def predict(self, recording):
        """Simulate the identified model on ``recording``'s input (open loop).

        Parameters
        ----------
        recording : Recording
            Held-out data with the model's input and output channels.

        Returns
        -------
        Recording
            The input channel and the predicted output (named as the recording's output), with
            the initial output derivatives fitted by least squares (``metadata["initial_state"]``).
        """
        model = self.model if self.model is not None else as_linear_ode_model(self.model_name)
        return predict_recording(model, self.coefficients, recording)
