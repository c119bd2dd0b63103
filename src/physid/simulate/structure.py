"""Simulation of structure models (`physid.models.structure.StructureModel`).

Linear structures are simulated exactly for inputs linear between samples (first-order hold):
in the modal coordinates z = V⁻¹x of ẋ = A x + B_s u (A = V Λ V⁻¹) each mode obeys

    z[k+1] = e^{λh} z[k] + h φ₁(λh) w[k] + h φ₂(λh) (w[k+1] − w[k]),   w = (V⁻¹B_s) u,

φ₁(s) = (e^s − 1)/s, φ₂(s) = (e^s − 1 − s)/s², a first-order recursion that
`scipy.signal.lfilter` runs over the whole record (no Python loop over samples). A defective A
(repeated eigenvalues without a full set of eigenvectors) falls back to the same FOH map in
matrix form, from `scipy.linalg.expm` of the augmented matrix. Nonlinear structures (cubic
springs, Coulomb friction as Fc·tanh(q̇/v_ε)) go through `scipy.integrate.solve_ivp` with tight
tolerances, the input interpolated linearly.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, SimulationError, arg

__all__ = ["simulate_structure", "structure_response"]


def _phi(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """φ₁(s) = (e^s − 1)/s and φ₂(s) = (e^s − 1 − s)/s², by Taylor series for |s| < 1e-3
    (the closed forms cancel there)."""
    s = np.asarray(s, dtype=complex)
    small = np.abs(s) < 1e-3
    safe = np.where(small, 1.0, s)
    e = np.exp(safe)
    p1 = np.where(small, 1 + s / 2 + s**2 / 6 + s**3 / 24, (e - 1) / safe)
    p2 = np.where(small, 0.5 + s / 6 + s**2 / 24 + s**3 / 120, (e - 1 - safe) / safe**2)
    return p1, p2


def _linear_states(A, Bs, u, dt, x0) -> np.ndarray:
    """States x[k] (n_samples, 2n) of ẋ = A x + B_s u, FOH input, exact."""
    from scipy.signal import lfilter

    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) > 1e8:
        return _linear_states_expm(A, Bs, u, dt, x0)
    G = np.linalg.solve(V, Bs.astype(complex))
    z0 = np.linalg.solve(V, x0.astype(complex))
    W = u @ G.T  # (n_samples, n_modes): w_i = g_i · u
    p1, p2 = _phi(lam * dt)
    Z = np.empty(W.shape, dtype=complex)
    for i in range(lam.size):  # one recursion per mode (a handful), each over the whole record
        b0, b1 = dt * p2[i], dt * (p1[i] - p2[i])
        zi = np.array([z0[i] - b0 * W[0, i]])  # makes the first output z0 exactly
        Z[:, i] = lfilter([b0, b1], [1.0, -np.exp(lam[i] * dt)], W[:, i], zi=zi)[0]
    return (Z @ V.T).real


def _linear_states_expm(A, Bs, u, dt, x0) -> np.ndarray:
    """The FOH map from expm of [[A, B, 0], [0, 0, I/h], [0, 0, 0]]·h, in matrix form (a true
    recursion: one small matrix product per sample)."""
    from scipy.linalg import expm

    n, m = Bs.shape
    big = np.zeros((n + 2 * m, n + 2 * m))
    big[:n, :n] = A * dt
    big[:n, n : n + m] = Bs * dt
    big[n : n + m, n + m :] = np.eye(m)
    E = expm(big)
    Ad, G1, G2 = E[:n, :n], E[:n, n : n + m], E[:n, n + m :]
    x = np.empty((u.shape[0], n))
    x[0] = x0
    drive = u[:-1] @ (G1 - G2).T + u[1:] @ G2.T
    for k in range(u.shape[0] - 1):
        x[k + 1] = Ad @ x[k] + drive[k]
    return x


def structure_response(model, t, u, params=None, *, x0=None, rtol: float = 1e-9):
    """States and outputs of a structure for given force samples (arrays in, arrays out).

    Parameters
    ----------
    model : StructureModel
    t : ndarray, shape (n_samples,) [s]
        Uniform sample times.
    u : ndarray, shape (n_samples, n_inputs) [N]
        Forces, in the order of ``model.input_names``; linear between samples.
    params : mapping, optional
        Parameter values (default nominal).
    x0 : ndarray, shape (2n,), optional
        Initial [q, q̇] (default rest).
    rtol : float
        Relative tolerance of the nonlinear integration.

    Returns
    -------
    x : ndarray (n_samples, 2n)
        [q [m], q̇ [m/s]].
    y : ndarray (n_samples, n_outputs)
        The outputs in the order of ``model.output_names``.
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float).reshape(t.size, -1)
    n = model.n
    x0 = np.zeros(2 * n) if x0 is None else np.asarray(x0, dtype=float)
    A, Bs, Cs, Ds = model.state_space(params)
    dt = float(t[1] - t[0])
    if not model.nonlinear:
        x = _linear_states(A, Bs, u, dt, x0)
        return x, x @ Cs.T + u @ Ds.T
    x = _nonlinear_states(model, t, u, params, x0, rtol)
    M = model.matrices(params)[0]
    fnl = model.nonlinear_forces(x[:, :n], x[:, n:], params, smooth=_V_EPS)
    y = x @ Cs.T + u @ Ds.T - fnl @ np.linalg.solve(M, np.eye(n)).T @ _acc_rows(model, n)
    return x, y


_V_EPS = 1e-4  # regularised Coulomb friction velocity [m/s] (models.structure.FRICTION_VELOCITY)


def _acc_rows(model, n) -> np.ndarray:
    """(n, n_outputs): picks q̈_i for each acceleration output (the nonlinear forces' share)."""
    S = np.zeros((n, len(model.outputs)))
    for r, (quantity, i) in enumerate(model.outputs):
        if quantity == "acceleration":
            S[i, r] = 1.0
    return S


def _nonlinear_states(model, t, u, params, x0, rtol) -> np.ndarray:
    from scipy.integrate import solve_ivp

    n = model.n
    A, Bs, _, _ = model.state_space(params)
    Minv = np.linalg.inv(model.matrices(params)[0])  # n×n, applied at every step
    friction = bool(model.friction_nodes)

    def rhs(tau, x):
        k = min(max(np.searchsorted(t, tau) - 1, 0), t.size - 2)
        frac = (tau - t[k]) / (t[k + 1] - t[k])
        uk = u[k] + frac * (u[k + 1] - u[k])
        dx = A @ x + Bs @ uk
        f = model.nonlinear_forces(x[None, :n], x[None, n:], params, smooth=_V_EPS)[0]
        dx[n:] -= Minv @ f
        return dx

    sol = solve_ivp(
        rhs,
        (t[0], t[-1]),
        x0,
        t_eval=t,
        method="LSODA" if friction else "DOP853",
        rtol=rtol,
        atol=1e-12,
        max_step=5 * (t[1] - t[0]),
    )
    if not sol.success or sol.y.shape[1] != t.size:
        raise SimulationError(
            f"the nonlinear simulation of {model.name!r} failed: {sol.message}. Check the "
            "parameter values (a negative k3 makes the Duffing spring unstable at large motion)."
        )
    return sol.y.T


def simulate_structure(model, t, forces, params=None, *, x0=None, states: bool = False):
    """Simulate a structure and return a `Recording` of its forces and outputs.

    Parameters
    ----------
    model : StructureModel or str
        The model (or a model file path).
    t : array_like, shape (n_samples,) [s]
        Uniform sample times (at least 2).
    forces : mapping or ndarray
        channel -> force samples [N] (one per entry of ``model.input_names``), or an array
        (n_samples, n_inputs) in that order; linear between samples.
    params : mapping, optional
        Parameter values (default nominal).
    x0 : array_like, shape (2n,), optional
        Initial [q, q̇].
    states : bool
        Also record q_i and qd_i of every node (channels ``q_<node>``, ``qd_<node>``).

    Returns
    -------
    Recording
        Channels: the forces [N], then the outputs (m, m/s or m/s²).

    Raises
    ------
    InputError
        A missing force channel, or arrays of the wrong length.

    Examples
    --------
    >>> import numpy as np, physid
    >>> from physid.simulate.structure import simulate_structure
    >>> m = physid.load_model("examples/models/chain2.toml")  # doctest: +SKIP
    """
    from ..models import load_model
    from ..signals.recording import Recording

    if isinstance(model, str):
        model = load_model(model)
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.allclose(np.diff(t), t[1] - t[0], rtol=1e-9):
        raise InputError(f"{arg('t')} must be uniformly spaced times (at least 2 samples).")
    if isinstance(forces, dict):
        missing = [c for c in model.input_names if c not in forces]
        if missing:
            raise InputError(
                f"{arg('forces')} lacks channel(s) {missing} of model {model.name!r}; give "
                f"{list(model.input_names)}."
            )
        u = np.column_stack([np.asarray(forces[c], dtype=float) for c in model.input_names])
    else:
        u = np.asarray(forces, dtype=float).reshape(t.size, -1)
    if u.shape != (t.size, len(model.input_names)):
        raise InputError(
            f"{arg('forces')} must have one row per sample ({t.size}) and one column per "
            f"input {list(model.input_names)}; got shape {u.shape}."
        )
    x, y = structure_response(model, t, u, params, x0=x0)
    names = [*model.input_names, *model.output_names]
    data = [u, y]
    units = [model.units[c] for c in names]
    if states:
        names += [f"q_{n}" for n in model.nodes] + [f"qd_{n}" for n in model.nodes]
        units += ["m"] * model.n + ["m/s"] * model.n
        data.append(x)
    return Recording(t, np.hstack(data), names, units, metadata={"model": model.name})
