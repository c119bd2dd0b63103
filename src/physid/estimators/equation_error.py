"""Equation-error identification of structures: filtered derivatives, regression on m, c, k, k3.

The equation of motion M q̈ + C q̇ + K q + f_nl(q, q̇) = B u is linear in the physical parameters
when each matrix entry is (a mass, a spring, a damper). With the displacement of every node
measured, one low-pass F₀ and its exact derivatives F₁ = s F₀, F₂ = s² F₀ (the consistent bank of
`physid.filters.filter_derivatives`, design="consistent") give

    Φ(F₂q, F₁q, F₀q) θ = B F₀u − φ₀        (exact for noise-free data, whatever the cut-off),

one equation per node and sample (the IDIM idea, Gautier & Khalil, for structures). The force
carries the scale, so every mass, stiffness and damping is determined (see
`StructureModel.identifiability`).

Noise and intervals. The measured force is the target of the regression: noise on it (the force
sensor's) is an equation error and does not bias the estimate. Noise on the displacements enters
the regressors (errors in variables) and biases least squares towards zero (≈ 1.4 % on the
two-mass chain at 40 dB); ``compensation="auto"`` removes it: each channel's noise variance is
estimated from its spectrum above the system's band (`channel_noise`), the regressors' noise
moments follow from the filters' taps, and they are subtracted from the normal equations
(bias-compensated least squares). The covariance is the sandwich H⁻¹ S H⁻ᵀ with S computed from
the filters' known correlation of the noise and the estimated variances of every sensor, force
included (`_covariance`); the result says when the force was measured with noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import EstimationError, InputError, arg
from .base import EstimatorMixin
from .results import ResultMixin

__all__ = ["EquationErrorEstimator", "StructureResult", "channel_noise", "fit_percent"]

_Z95 = 1.959963984540054


def fit_percent(y, y_hat) -> np.ndarray:
    """MATLAB ``compare``'s fit 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖) [%] per column.

    Parameters
    ----------
    y, y_hat : ndarray, shape (n_samples, n_outputs)

    Returns
    -------
    ndarray, shape (n_outputs,)

    Examples
    --------
    >>> float(fit_percent(np.array([[0.0], [2.0]]), np.array([[0.0], [2.0]]))[0])
    100.0
    """
    y, y_hat = np.atleast_2d(y), np.atleast_2d(y_hat)
    den = np.linalg.norm(y - y.mean(axis=0), axis=0)
    return 100.0 * (1.0 - np.linalg.norm(y - y_hat, axis=0) / np.where(den > 0, den, np.nan))


def channel_noise(x, dt: float, band: float) -> dict:
    """White-noise level of a channel from its spectrum above the system's band.

    The one-sided power spectral density (Welch, 1024-sample Hann segments) is averaged over
    the frequencies above max(3·band, fs/4) (the mean: the median of the Welch bins is biased
    low by about 1/(9K) for K segments), where a structure's response and a
    band-limited excitation have decayed to nothing but the sensor noise; a flat floor S₀
    [unit²/Hz] there means a white-noise variance σ² = S₀ · fs/2.

    Parameters
    ----------
    x : ndarray, shape (n_samples,)
        The channel.
    dt : float [s]
        Sample period.
    band : float [rad/s]
        Upper edge of the system's band (its highest natural frequency).

    Returns
    -------
    dict
        ``variance`` (σ², None when the band reaches Nyquist), ``variance_stderr`` (standard
        error of σ²: σ² √(κ / (K·B)) for K Welch segments and B bins averaged, κ = 2.2 measured
        by Monte Carlo for Hann segments with 50 % overlap, whose bins are correlated),
        ``snr_db`` (10 log10 of the signal's variance over σ²; inf for a noise-free channel).
    """
    from scipy.signal import welch

    fs = 1.0 / dt
    f_lo = max(3.0 * band / (2 * np.pi), fs / 4)
    if f_lo >= 0.45 * fs or x.size < 2048:
        return {"variance": None, "variance_stderr": None, "snr_db": None}
    f, p = welch(x - np.mean(x), fs=fs, nperseg=1024)
    above = f > f_lo
    floor = float(np.mean(p[above]))
    var = floor * fs / 2
    segments = (x.size - 1024) // 512 + 1
    stderr = var * float(np.sqrt(2.2 / (segments * np.count_nonzero(above))))
    total = float(np.var(x))
    tiny = var <= 1e-30 * max(total, 1e-300)
    with np.errstate(divide="ignore"):  # a channel of pure noise: -inf dB, said as such
        snr = np.inf if tiny else 10 * np.log10(max(total - var, 0) / var)
    return {"variance": var, "variance_stderr": stderr, "snr_db": float(snr)}


@dataclass(frozen=True)
class StructureResult(ResultMixin):
    """Identified physical parameters of a structure (the shared result schema).

    Attributes
    ----------
    method : str
        ``"equation-error"`` or ``"output-error"``.
    names : tuple of str
        Fitted parameters.
    parameters : dict
        name -> value (SI).
    stderr : dict or None
        name -> standard error (None with ``stderr_reason``).
    covariance : ndarray or None
        Covariance of ``names`` (p, p).
    fit_percent : dict
        Output channel -> fit [%] of the simulated output on the fitting record.
    noise : dict
        Channel -> ``{"variance", "snr_db"}`` estimated from the spectrum above the band.
    input_noisy : bool
        A force was measured with noise (errors in variables; said in ``message``).
    estimator : str
        What solved it (``"least squares"``, ``"instrumental variables (delayed rows)"``, …).
    """

    method: str
    names: tuple
    parameters: dict
    stderr: dict | None
    stderr_reason: str | None
    units: dict
    success: bool
    message: str
    covariance: Any = None
    fit_percent: dict = field(default_factory=dict)
    noise: dict = field(default_factory=dict)
    input_noisy: bool = False
    estimator: str = ""
    settings: dict = field(default_factory=dict)
    known: dict = field(default_factory=dict)
    model_name: str = ""
    derived: dict = field(default_factory=dict)
    model: Any = field(default=None, repr=False, compare=False)
    _private_fields = ("model",)

    def confidence_intervals(self, level: float = 0.95) -> dict:
        """name -> (low, high) normal intervals (empty when the errors are withheld).

        Parameters
        ----------
        level : float
            Only 0.95 is tabulated.

        Returns
        -------
        dict
        """
        if level != 0.95:
            raise InputError(f"{arg('level')} must be 0.95; got {level!r}.")
        if self.stderr is None:
            return {}
        return {
            k: (v - _Z95 * self.stderr[k], v + _Z95 * self.stderr[k])
            for k, v in self.parameters.items()
        }

    def modal(self):
        """Natural frequencies, damping ratios and mode shapes with delta-method errors.

        Returns
        -------
        ModalParameters
            Errors are None when the result has no covariance.
        """
        cov = None if self.covariance is None else np.asarray(self.covariance, dtype=float)
        return self.model.modal(
            {**self.known, **self.parameters}, cov, self.names if cov is not None else None
        )

    def predict(self, recording):
        """Simulate the identified model on a recording's forces (from rest).

        Parameters
        ----------
        recording : Recording
            With the model's force channels.

        Returns
        -------
        Recording
            The forces and the simulated outputs.
        """
        from ..simulate.structure import simulate_structure

        forces = {c: recording[c] for c in self.model.input_names}  # and base displacements
        return simulate_structure(
            self.model, recording.t, forces, {**self.known, **self.parameters}
        )

    def fit_to(self, recording) -> dict:
        """Fit [%] of each simulated output against ``recording`` (held-out validation).

        Parameters
        ----------
        recording : Recording

        Returns
        -------
        dict
            Output channel -> fit [%].
        """
        sim = self.predict(recording)
        names = self.model.output_names
        fits = fit_percent(recording.select(names), sim.select(names))
        return dict(zip(names, map(float, fits), strict=True))


def _structure(model):
    from ..models import load_model

    if isinstance(model, str):
        model = load_model(model)
    if not hasattr(model, "nodes") or not hasattr(model, "regression"):
        raise InputError(
            f'{arg("model")} must be a structure model (a kind = "structure" file); got '
            f"{type(model).__name__}."
        )
    return model


def _check_unknown(model, unknown) -> tuple:
    unknown = tuple(model.unknown if unknown is None else unknown)
    bad = [u for u in unknown if u not in model.parameter_names]
    if bad or not unknown:
        raise InputError(
            f"{arg('unknown')} must name parameters of {model.name!r} "
            f"({list(model.parameter_names)}); got {list(unknown)}."
        )
    return unknown


def record_arrays(model, recording):
    """The forces (n, n_inputs) and outputs (n, n_outputs) of a recording, and its period."""
    missing = [c for c in (*model.input_names, *model.output_names) if c not in recording.names]
    if missing:
        bases = [
            f"{c!r} is the measured displacement of base {node!r}"
            for c, node in zip(model.base_names, model.base_nodes, strict=True)
            if c in missing
        ]
        raise InputError(
            f"the recording lacks channel(s) {missing} of model {model.name!r} ({model.source}"
            + (f"; {', '.join(bases)}" if bases else "")
            + f"); it has {list(recording.names)}. Map them with {arg('channels')} or the "
            "model file's [recording] table."
        )
    return recording.select(model.input_names), recording.select(model.output_names), recording.dt


def noise_report(model, u, y, dt, params=None, inputs=None) -> tuple[dict, bool, float]:
    """Each channel's estimated noise, whether one of ``inputs`` (default every input, forces
    and base displacements) is noisy (SNR < 60 dB) and the band."""
    band = float(np.max(model.modal(params).frequency, initial=0.0)) or 1.0
    noise = {}
    for name, col in zip(model.input_names, u.T, strict=True):
        noise[name] = channel_noise(col, dt, band)
    for name, col in zip(model.output_names, y.T, strict=True):
        noise[name] = channel_noise(col, dt, band)
    inputs = model.input_names if inputs is None else inputs
    noisy = any(noise[c]["snr_db"] is not None and noise[c]["snr_db"] < 60 for c in inputs)
    return noise, noisy, band


class EquationErrorEstimator(EstimatorMixin):
    """Equation-error (filtered-derivative) estimator of a structure's physical parameters.

    Parameters
    ----------
    model : StructureModel or str
        Every node's displacement must be an output.
    unknown : sequence of str, optional
        Parameters to estimate (default the model's ``identify = true`` ones).
    cutoff : float [rad/s], optional
        Cut-off of the low-pass F₀ (default 3 × the highest natural frequency at the nominal
        values; 10 × with cubic springs or friction, whose harmonics lie above the band).
    half_width : int, optional
        M (2M + 1 taps; default 2·2π/Ω_g, two periods of the cut-off, at least 10).
    compensation : {"auto", "none"}
        ``"auto"``: remove the bias the displacement noise puts into the regressors (errors in
        variables), with each channel's noise variance estimated from its spectrum above the
        band; ``"none"``: plain least squares.

    Attributes
    ----------
    result_ : StructureResult
        After `fit`.
    """

    method = "equation-error"

    def __init__(self, model, *, unknown=None, cutoff=None, half_width=None, compensation="auto"):
        self.model = model
        self.unknown = unknown
        self.cutoff = cutoff
        self.half_width = half_width
        self.compensation = compensation

    def fit(self, recording):
        """Estimate the parameters from a recording of the forces and every displacement.

        Parameters
        ----------
        recording : Recording
            Uniformly sampled; channels ``model.input_names`` [N] and ``model.output_names``.

        Returns
        -------
        self
        """
        from ..filters import design_filter_bank, filter_derivatives

        model = _structure(self.model)
        unknown = _check_unknown(model, self.unknown)
        if self.compensation not in ("auto", "none"):
            raise InputError(
                f"{arg('compensation')} must be 'auto' or 'none'; got {self.compensation!r}."
            )
        order = _displacement_columns(model)
        u, y, dt = record_arrays(model, recording)
        # base displacements are regressors like the nodes' (their noise is compensated alike);
        # only a noisy force is an error in the target
        noise, noisy, band = noise_report(model, u, y, dt, inputs=model.force_names)
        # a nonlinear structure answers with harmonics (3ω of a cubic spring) above its band
        factor = 10.0 if model.nonlinear else 3.0
        cutoff = float(self.cutoff) if self.cutoff is not None else factor * band
        omega = min(cutoff * dt, 0.9 * np.pi)
        half = int(self.half_width) if self.half_width else max(10, int(np.ceil(4 * np.pi / omega)))
        if y.shape[0] < 10 * (2 * half + 1):
            raise InputError(
                f"the recording has {y.shape[0]} samples; equation-error needs at least 10 times "
                f"the filter's {2 * half + 1} taps. Record longer or lower {arg('half_width')}."
            )
        m = len(model.force_names)
        q = np.hstack([y[:, order], u[:, m:]])  # the nodes, then the bases' x_b
        raw = np.hstack([q, u[:, :m], model.cubic_elongations(q) ** 3])
        d = filter_derivatives(raw, recording.t, half, omega, design="consistent")
        N = q.shape[1]  # F₁x_b is the base velocity the equation needs, from the same bank
        Q0, Q1, Q2 = d.value[:, :N], d.first[:, :N], d.second[:, :N]
        U0 = d.value[:, N : N + m]
        cubes = d.value[:, N + m :]
        signs = np.sign(Q1[:, list(model.friction_nodes)])
        Phi, phi0 = model.regression(Q0, Q1, Q2, unknown, cubes=cubes, signs=signs)
        target = U0 @ model.input_matrix.T - phi0  # (rows, n)
        R = r = None
        how = "least squares"
        taps = np.array(
            [f.taps for f in design_filter_bank(half, omega, recording.dt, "consistent")]
        )
        unit_reg = _unit_regression(model, unknown)
        measured = [model.output_names[c] for c in order] + list(model.base_names)
        out_var = np.array([noise[c]["variance"] or 0.0 for c in measured])
        in_var = np.array([noise[c]["variance"] or 0.0 for c in model.force_names])
        if self.compensation == "auto" and np.any(out_var > 0):
            R, r = _noise_moments(unit_reg, taps, out_var)
            how = (
                "bias-compensated least squares (displacement noise variances from their "
                "spectra above the band)"
            )
        theta, H = _solve(Phi, target, R, r)
        cov = _covariance(Phi, H, theta, unit_reg, taps, out_var, in_var, model.input_matrix)
        if R is not None:  # the compensation's own error: it uses estimated variances
            out_se = [noise[c]["variance_stderr"] or 0.0 for c in measured]
            cov = cov + _compensation_covariance(H, theta, unit_reg, taps, out_se, Phi.shape[0])
        self.result_ = _result(model, unknown, theta, cov, how, noise, noisy, recording, self)
        self.result_settings_ = {"cutoff": cutoff, "half_width": half}
        object.__setattr__(self.result_, "settings", {"cutoff": cutoff, "half_width": half})
        return self


def _displacement_columns(model) -> list:
    """Output column of each node's displacement (all nodes must have one)."""
    where = {i: r for r, (quantity, i) in enumerate(model.outputs) if quantity == "displacement"}
    missing = [model.nodes[i] for i in range(model.n) if i not in where]
    if missing:
        raise EstimationError(
            f"equation-error needs the displacement of every node; {missing} have none in model "
            f"{model.name!r}. Use {arg('method', 'output-error')}, which fits any outputs "
            "(velocities, accelerations, a subset of the nodes)."
        )
    return [where[i] for i in range(model.n)]


def _unit_regression(model, unknown):
    """The regression of unit samples: row s = k·n + j is F_k q_j = 1 (k = 0, 1, 2); n counts
    the nodes and then the bases (their x_b are regressors too)."""
    n = model.n + len(model.base_nodes)
    unit = np.zeros((3 * n, 3, n))
    for k in range(3):
        unit[k * n + np.arange(n), k, np.arange(n)] = 1.0
    return model.regression(
        unit[:, 0],
        unit[:, 1],
        unit[:, 2],
        unknown,
        cubes=np.zeros((3 * n, len(model.cubic_elongations(unit[:1, 0]).T))),
        signs=np.zeros((3 * n, len(model.friction_nodes))),
    )


def _noise_moments(unit_reg, taps, variances):
    """Per-row noise moments of the regression: R = E[φₙ φₙᵀ] (p, p) and r = E[φₙ eₙ] (p,).

    The regression is linear in the filtered signals F_k q_j (k = 0, 1, 2), so its noise part is
    Σ_s W_s η_s with η_s = F_k n_j; W_s is the regression of a unit sample of that signal, and
    E[η_s η_s'] = σ_j² ⟨f_k, f_k'⟩ δ_jj' from the filters' taps. The target's noise part is the
    held parameters' share φ₀ of the same signals (the force's noise is independent of it).
    """
    Phi_u, phi0_u = unit_reg
    C = np.kron(taps @ taps.T, np.diag(variances))  # index s = k·n + j, as in the unit rows
    R = np.einsum("sip,st,tiq->pq", Phi_u, C, Phi_u)
    r = -np.einsum("sip,st,ti->p", Phi_u, C, phi0_u)
    return R, r


def _solve(Phi, target, R=None, r=None):
    """θ and H = Σ_t (φ_t φ_tᵀ − R) by (bias-compensated) least squares.

    Normal equations Σ_t (φ_t φ_tᵀ − R) θ = Σ_t (φ_t y_t − r), R and r the regressors' noise
    moments per row (`_noise_moments`; zero without compensation): the estimating function
    g_t = φ_t e_t + R θ − r has mean zero at the true θ. Columns are scaled to unit norm.
    """
    rows, n, p = Phi.shape
    R = np.zeros((p, p)) if R is None else R
    r = np.zeros(p) if r is None else r
    Xf, Yf = Phi.reshape(-1, p), target.reshape(-1)
    H = Xf.T @ Xf - rows * R
    scale = np.sqrt(np.abs(np.diag(H)))
    scale[scale == 0] = 1.0
    Hs = H / np.outer(scale, scale)
    if not np.all(np.isfinite(Hs)) or np.linalg.cond(Hs) > 1e12:
        raise EstimationError(
            "the regressor is rank-deficient: the record does not excite every parameter (or "
            "the parameters are not identifiable from these outputs); use a broader-band force."
        )
    theta = np.linalg.solve(Hs, (Xf.T @ Yf - rows * r) / scale) / scale
    return theta, H


def _covariance(Phi, H, theta, unit_reg, taps, out_var, in_var, Bmat):
    """Covariance H⁻¹ S H⁻ᵀ of θ from the filters' known correlation of the noise.

    The equation error of node i is e_i = Σ_j h_ij ⋆ n_j + Σ_c B_ic f₀ ⋆ n_c: displacement noise
    n_j through h_ij = −Σ_k W_i,(k,j)(θ) f_k (W the unit-sample regression) and force noise n_c
    through f₀ (⋆: the filters' correlation y[t] = Σ_k h[k] x[t+k]). Then Σ_t φ_t·e_t =
    Σ_src Σ_m n_src[m] v_src[m] with v_src = Σ_i φ_i ∗ h_i,src (a convolution), so
    S = Σ_src σ_src² v_srcᵀ v_src: no lag window to choose, and far less sampling noise than a
    HAC estimate (whose lag sums nearly cancel for derivative-filtered noise). Second-order
    noise terms are neglected (they are O(1/SNR) smaller).
    """
    from scipy.signal import fftconvolve

    Phi_u, phi0_u = unit_reg
    n = Phi.shape[1]
    W = np.einsum("sip,p->is", Phi_u, theta) + phi0_u.T  # (n, 3N), N nodes and bases
    N = W.shape[1] // 3
    p = Phi.shape[2]
    S = np.zeros((p, p))
    sources = [(var, -np.einsum("ik,kt->it", W[:, j::N], taps)) for j, var in enumerate(out_var)]
    sources += [(var, np.outer(Bmat[:, c], taps[0])) for c, var in enumerate(in_var)]
    for var, h in sources:
        if not var:
            continue
        v = sum(fftconvolve(Phi[:, i, :], h[i][:, None], mode="full", axes=0) for i in range(n))
        S += var * (v.T @ v)
    S += _second_order(Phi_u, W, taps, out_var, Phi.shape[0])
    inv = np.linalg.solve(H, np.eye(p))
    return inv @ S @ inv.T


def _second_order(Phi_u, W, taps, out_var, rows):
    """The noise × noise part of Var(Σ_t φ_t·e_t) that the noisy regressors leave out.

    With φ_t = φ̄_t + φ̃_t, the score Σ_t φ_t·e_t has a part quadratic in the displacement noise,
    Σ_t φ̃_t·e_t, and for Gaussian noise (Isserlis) its covariance is
    Σ_t,s [E φ̃_t φ̃_sᵀ · E e_t e_s + E φ̃_t e_s · E e_t φ̃_sᵀ]. The first term is already in
    `_covariance`'s S, computed with the noisy regressors; this is the second, the regressors'
    noise correlated with the equation error (e = −φ̃ᵀθ + …): with C_ij(τ) = E φ̃_i,t e_j,t+τ
    (p-vectors, nodes i, j), it is N Σ_τ Σ_ij C_ij(τ) C_ji(−τ)ᵀ for N rows (stationary noise).
    """
    from scipy.signal import fftconvolve

    n, N = W.shape[0], W.shape[1] // 3  # equations (nodes); measured signals (nodes, bases)
    L = taps.shape[1]
    C = np.zeros((n, n, 2 * L - 1, Phi_u.shape[2]))
    for j, var in enumerate(out_var):
        if not var:
            continue
        a = np.einsum("kip,kl->ilp", Phi_u[j::N], taps)  # φ̃_i's taps on n_j, (n, L, p)
        h = -np.einsum("ik,kl->il", W[:, j::N], taps)  # e_i's taps on n_j, (n, L)
        for i in range(n):
            # C_ik(τ) = σ_j² Σ_m a_i[m + τ] h_k[m], τ = −(L−1) … L−1
            C[i] += var * fftconvolve(a[i][None], h[:, ::-1, None], mode="full", axes=1)
    return rows * np.einsum("ijtp,jitq->pq", C, C[:, :, ::-1, :])


def _compensation_covariance(H, theta, unit_reg, taps, variance_stderr, rows):
    """Covariance the estimated noise variances add through the bias compensation.

    θ̂ solves (ΦᵀΦ − N R(σ²)) θ = Φᵀy − N r(σ²) with R, r linear in σ² (`_noise_moments`), so
    ∂θ̂/∂σ_j² = −N H⁻¹ (R_j θ − r_j), R_j, r_j the moments of a unit variance on channel j. The
    variances come from the spectrum above the band, where the regressors have no power, so
    their errors are independent of the score: each adds gⱼ gⱼᵀ Var(σ̂_j²).
    """
    p = H.shape[0]
    extra = np.zeros((p, p))
    for j, se in enumerate(variance_stderr):
        if not se:
            continue
        R_j, r_j = _noise_moments(unit_reg, taps, np.eye(len(variance_stderr))[j])
        g = rows * np.linalg.solve(H, R_j @ theta - r_j)
        extra += se**2 * np.outer(g, g)
    return extra


def _result(model, unknown, theta, cov, how, noise, noisy, recording, est) -> StructureResult:
    from ..simulate.structure import structure_response

    params = dict(zip(unknown, map(float, theta), strict=True))
    known = {k: v for k, v in model.parameters.items() if k not in params}
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    stderr = dict(zip(unknown, map(float, se), strict=True))
    u, y, _ = record_arrays(model, recording)
    messages = []
    success = all(np.isfinite(theta))
    fits = {}
    try:
        _, y_hat = structure_response(model, recording.t, u, {**known, **params})
        fits = dict(zip(model.output_names, map(float, fit_percent(y, y_hat)), strict=True))
    except Exception as exc:  # noqa: BLE001 - an unstable estimate cannot be simulated
        messages.append(f"the estimate could not be simulated ({exc})")
        success = False
    ident = model.identifiability(unknown)
    if ident.unidentifiable:
        success = False
        messages.append(ident.message)
    bad = [k for k in model.nonlinear_names if k in params and not abs(params[k]) > 2 * stderr[k]]
    if bad:
        messages.append(f"{', '.join(bad)} not distinguishable from 0 in this record")
    if noisy:
        snrs = ", ".join(
            f"{c} ≈ {noise[c]['snr_db']:.0f} dB" for c in model.force_names if noise[c]["snr_db"]
        )
        messages.append(
            f"the force is measured with noise ({snrs}, from its spectrum above the band): "
            "errors in the variables; the force is the regression's target, so its noise does "
            "not bias the estimate, and the intervals include it"
        )
    messages.append(f"solved by {how}")
    units = {k: model.units.get(k, "") for k in params}
    return StructureResult(
        method="equation-error",
        names=tuple(unknown),
        parameters=params,
        stderr=stderr,
        stderr_reason=None,
        units=units,
        success=bool(success),
        message="; ".join(messages) + ".",
        covariance=cov,
        fit_percent=fits,
        noise=noise,
        input_noisy=bool(noisy),
        estimator=how,
        known=known,
        model_name=model.name,
        model=model,
    )
