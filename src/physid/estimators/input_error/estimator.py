"""The input-error estimator (`InputErrorEstimator`): settings, and the three steps of `fit`.

Part of `physid.estimators.input_error`: the steps are `.prepare`, `.solve` and `.conclude`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from ...errors import InputError, arg
from ..base import EstimatorMixin
from ..idim.base_parameters import unit_of
from .conclude import conclude
from .linear import linear_in_parameters, prepare_base, refuse_nonlinear_settings, solve_base
from .prepare import check_settings, filter_recording, prepare
from .solve import solve

#: What `InputErrorEstimator` estimates (``parameters=``).
PARAMETER_SETS = ("auto", "model", "base")


class InputErrorEstimator(EstimatorMixin):
    """Identify the physical parameters of a chain model by the input-error (inverse-model) method.

    Parameters
    ----------
    model : ChainModel
        From ``physid.load_model("manipulator")`` or a TOML model file; needs ``parameter_names``,
        ``parameters``, ``n_joints``, ``inverse_dynamics`` and ``parameter_jacobian`` (and
        ``regressor``/``beta`` for ``start="linear"``).
    half_width : int, optional
        Filter half-width M (2M + 1 taps, M samples lost at each end). Paper: 100. Default:
        chosen from the data with ``cutoff="auto"``, else 100.
    cutoff : float [rad/sample] or "auto"
        Filter cut-off Ω_g (0 < Ω_g <= π). Paper: 0.2 (31.8 Hz at Δ = 1 ms). ``"auto"``
        (default): M (unless given) and Ω_g chosen from the spectrum of q by
        `physid.filters.choose_filter` (the lowest-noise filter whose flat band holds the
        motion); the choice and its reason are in ``result.filter_choice``.
    torque : {"measured", "pd"}
        ``"measured"``: low-pass the recording's ``tau1..taun`` [N·m]. ``"pd"``: rebuild the
        filtered torque from the PD law ``Kp (r^f - q^f) - Kd q̇^f`` with the references
        ``r1..rn`` [rad], as the paper does.
    kp, kd : float or sequence of float, optional
        PD gains [N·m/rad], [N·m·s/rad] for ``torque="pd"``; default: the recording's metadata.
        Given with ``torque="measured"`` they would be unused, so that is an `InputError`.
    fixed : mapping name -> value, or sequence of names, optional
        Parameters to hold at the given values (``{"l1": 0.4}``), or names held at their
        starting values (``["l1"]``: the value in ``initial=`` of `fit`, else the model's
        nominal one). A parameter given different values in ``initial=`` and ``fixed=`` is an
        `InputError`. Each structurally unidentifiable combination that ``fixed`` does not touch
        gets one parameter held at its initial value, with an
        `~physid.models.identifiability.IdentifiabilityWarning`.
    bounds : mapping name -> (low, high), optional
        Overrides of the default bounds; by default a parameter with a positive initial value is
        kept above ``1e-6`` times it (masses and lengths stay positive), others are free.
    start : {"initial", "linear"}
        ``"initial"``: start the fit from the initial values (the paper's experiment).
        ``"linear"``: first solve the linear least-squares problem in the model's base
        parameters ``β`` (the model is linear in them), then fit θ to ``β̂`` through the
        triangular factor of the regressor, a problem of ``n_beta`` rows that has exactly the same
        minimiser; the main fit then starts at (almost) the optimum.
    derivatives : {"consistent", "paper"}
        ``"consistent"`` (default): derivative filters built from the low-pass so that
        ``F_k = s^k F0`` holds in the pass band (`physid.filters.design_filter_bank`); removes the
        ~3 % bias of m1*l1**2 that the paper's pair leaves. ``"paper"``: the paper's
        ``Filtr1``/``Filtr2``, to reproduce its numbers.
    max_nfev : int
        Budget of residual evaluations of the main fit.
    hold_unidentifiable : bool
        Hold one parameter of each unidentifiable combination (default). With False the fit
        raises `~physid.errors.IdentifiabilityError` instead of wandering along the valley.
    check_filter : bool
        Warn (`FilterWarning`) when the motion's spectrum reaches beyond the flat part of the
        filter's pass band (`filter_band_check`, before the fit) and when the filtered equations
        of motion do not balance at the optimum (relative rms residual above ``RESIDUAL_WARN``).
    uncertainty : {"hac", "iid"}
        How ``stderr`` is computed. ``"hac"`` (default): the sandwich covariance with the
        residual's autocorrelation over ``2M`` lags (`sandwich_covariance`), valid for the
        filtered, coloured residual. ``"iid"``: ``s² (JᵀJ)⁻¹``, as if the residuals were
        independent (optimistic by 2–8x on noisy data; kept for comparison, and always reported
        as ``result.stderr_iid``). Neither covers the errors-in-variables *bias* that noise on q
        causes (``docs/input-error.md``).
    noise : {"auto", "compensate", "ignore"}
        What to do about white noise on q, which biases the inertias towards zero
        (errors-in-variables). ``"compensate"``: estimate the noise level from the spectrum of q
        (`physid.filters.noise_floor`), and remove its bias from the normal equations of the
        model's linear form ``τ = Y β(θ)`` with ``noise_replicates`` re-noised copies of the
        record (`.solve.solve_compensated`); the standard errors then come from the same
        replicates (they ignore ``uncertainty``). Needs ``regressor``/``beta`` on the model.
        ``"ignore"``: plain least squares; the message says when q is noisy (the paper's
        setting, used by the demo's reproduction). ``"auto"`` (default): ``"compensate"`` when
        the spectrum of q shows a noise floor a cut-off could pass (`FilterChoice.noisy`) and
        the model has the linear form, else ``"ignore"`` (`.solve.resolve_noise`);
        ``result.noise`` says which ran. On the paper's arm with 1e-4 rad of noise the default
        (``cutoff="auto"``, ``noise="auto"``) removes the ~2.4 % bias of m1 and its 95 %
        intervals hold the truth in 95 % of 400 trials, where ``"ignore"`` gives 99.9 % (too
        wide) with the automatic filter and 45.6 % with the paper's (benchmark
        ``bench_coverage_input_error.py``; docs/input-error.md). Costs ``noise_replicates``
        filterings and regressor evaluations of the record when it compensates.
    noise_replicates : int
        Re-noised copies for ``noise="compensate"`` (default 30).
    random_state : int or None
        Seed of those copies (default 0: the same data give the same estimate).
    parameters : {"auto", "model", "base"}
        What is estimated. ``"model"``: the model's own parameters θ (the paper's masses and
        lengths), by nonlinear least squares. ``"base"``: for a model linear in its parameters
        (rigid-body and URDF models, ``τ = Y θ``), the base parameters β = K θ (the identifiable
        combinations, named by their leading standard parameter as in IDIM's results); the
        residual is then linear, its Jacobian is the base regressor W_b on the filtered
        signals, and one exact least-squares step is the minimum (`.linear`). ``fixed=`` and
        ``bounds=`` do not apply there, ``start``/``max_nfev`` are unused. ``"auto"``
        (default): ``"base"`` for models linear in their parameters, else ``"model"``.
    xtol, ftol, gtol : float
        Tolerances passed to `scipy.optimize.least_squares`.

    Warns
    -----
    FilterWarning
        The filter's pass band does not cover the motion, or the equations do not balance.
    IdentifiabilityWarning
        A parameter of an unidentifiable combination is held at its initial value.
    BoundWarning
        Parameters ended on a bound (likely model mismatch); they are named in ``message``,
        their ``stderr`` is NaN and ``success`` is False.

    Examples
    --------
    The paper's experiment (noise-free, paper's kinetic energy) with the paper's M = 100,
    Ω_g = 0.2 and the default consistent derivative filters recovers m2 = 25 kg to 0.001 %; m1 and
    l1 can only be identified as m1*l1**2, so l1 is held (with a warning):

    >>> import warnings, physid
    >>> from physid.simulate.closed_loop import paper_manipulator_experiment
    >>> model = physid.load_model("manipulator", kinetic="paper")
    >>> rec = paper_manipulator_experiment(kinetic="paper", model=model)
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     result = InputErrorEstimator(model, torque="pd").fit(rec, initial={"m2": 25.1}).result_
    >>> round(result.parameters["m2"], 2), result.unidentifiable, result.fixed
    (25.0, ('m1*l1**2',), {'l1': 0.4})
    """

    def __init__(
        self,
        model,
        *,
        half_width: int | None = None,
        cutoff: float | str = "auto",
        torque: str = "measured",
        kp=None,
        kd=None,
        fixed: Mapping[str, float] | None = None,
        bounds: Mapping[str, tuple[float, float]] | None = None,
        start: str = "initial",
        derivatives: str = "consistent",
        max_nfev: int = 200,
        hold_unidentifiable: bool = True,
        check_filter: bool = True,
        uncertainty: str = "hac",
        noise: str = "auto",
        noise_replicates: int = 30,
        random_state: int | None = 0,
        parameters: str = "auto",
        xtol: float = 1e-12,
        ftol: float = 1e-12,
        gtol: float = 1e-12,
    ) -> None:
        self.model = model
        self.half_width = half_width
        self.cutoff = cutoff
        self.torque = torque
        self.kp = kp
        self.kd = kd
        self.fixed = fixed
        self.bounds = bounds
        self.start = start
        self.derivatives = derivatives
        self.max_nfev = max_nfev
        self.hold_unidentifiable = hold_unidentifiable
        self.check_filter = check_filter
        self.uncertainty = uncertainty
        self.noise = noise
        self.noise_replicates = noise_replicates
        self.random_state = random_state
        self.parameters = parameters
        self.xtol = xtol
        self.ftol = ftol
        self.gtol = gtol

    def _check_settings(self) -> None:
        check_settings(self)

    def parameter_set(self) -> str:
        """``"model"`` or ``"base"``: what `fit` estimates (``parameters="auto"`` resolved).

        Returns
        -------
        str
        """
        if self.parameters not in PARAMETER_SETS:
            raise InputError(
                f"parameters must be one of {PARAMETER_SETS}; got {self.parameters!r}."
            )
        linear = linear_in_parameters(self.model)
        if self.parameters == "base" and not linear:
            raise InputError(
                f"{arg('parameters', repr('base'), cli='base')} needs a model linear in its "
                "parameters (a rigid-body or URDF model, with regressor and base_parameters); "
                f"{type(self.model).__name__} is not. Use "
                f"{arg('parameters', repr('model'), cli='model')}."
            )
        if self.parameters == "auto":
            return "base" if linear else "model"
        return self.parameters

    def filtered_signals(self, recording):
        """Filter a recording: ``(t_valid, q^f, q̇^f, q̈^f, τ^f, dt, q)``.

        ``t_valid`` (n_valid,) [s]; ``q^f, q̇^f, q̈^f, τ^f`` (n_valid, n_joints) in rad, rad/s,
        rad/s², N·m; ``dt`` the sample period [s]; ``q`` the raw angles (n_samples, n_joints)
        [rad]. With ``cutoff="auto"`` the filter is chosen first (`physid.filters.choose_filter`).

        Raises `DataFileError` for missing channels, `ShapeError` when the recording's number of
        joints differs from the model's, `SamplingError` when it is shorter than the filter.
        """
        f = filter_recording(self, recording)
        return f.t, f.qf, f.qdf, f.qddf, f.tau_f, f.dt, f.q

    def fit(self, recording, initial: Mapping[str, float] | None = None) -> InputErrorEstimator:
        """Estimate the parameters from ``recording``; the result is in ``self.result_``.

        Three steps: `.prepare.prepare` (filter, check the filter band, plan what is held,
        bounds and start, identifiability at the start), `.solve.solve` (optional linear start,
        the least-squares fit, parameters that ended on a bound) and `.conclude.conclude` (the
        residual check, the uncertainty and the result object). Over base parameters the first
        two are `.linear.prepare_base` and `.linear.solve_base`.

        Parameters
        ----------
        recording : Recording
            Uniformly sampled ``t``, ``q1..qn`` [rad] and ``tau1..taun`` [N·m] (torque="measured")
            or ``r1..rn`` [rad] (torque="pd").
        initial : mapping name -> value, optional
            Starting values; missing names take the model's nominal values. Unused over base
            parameters (a linear problem needs no start).

        Returns
        -------
        self
        """
        base = self.parameter_set() == "base"
        if base:
            refuse_nonlinear_settings(self)
            problem = prepare_base(self, recording)
            solution = solve_base(self, problem)
        else:
            problem = prepare(self, recording, initial)
            solution = solve(self, problem)
        result = conclude(self, problem, solution, (recording,))
        if base:
            bp = problem.base
            columns = tuple(bp.independent)
            result = replace(
                result,
                parameter_set="base",
                base_expressions=dict(zip(problem.names, bp.expressions, strict=True)),
                columns=columns,
                fixed={},
                # a base parameter has the unit of its kept column (as in IDIM's results)
                units={
                    n: unit_of(c, self.model) for n, c in zip(problem.names, columns, strict=True)
                },
            )
        result = replace(result, model=self.model)
        self.result_ = result
        self.structural_ = problem.structural
        self.numeric_before_ = problem.before
        self.numeric_after_ = solution.after
        return self
