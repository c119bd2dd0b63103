"""The robotics recipe for IDIM, written from numpy, scipy and pinocchio alone (no physid).

What practitioners do (Gautier, Swevers, Gaz et al.; the usual tutorial pipeline):

1. zero-phase 4th-order Butterworth low-pass (``scipy.signal.butter`` + ``filtfilt``) of the
   measured q and τ at ``fc`` = 5× the trajectory bandwidth (the case says what a practitioner
   knows of it: the highest harmonic of the excitation);
2. q̇, q̈ by central differences (``np.gradient``) of the filtered q;
3. 3/fc s dropped at both ends (filter transients), then one sample in nd kept, nd = fs/(5 fc)
   (a Nyquist of 2.5× the cut-off; q and τ are already low-passed, so nothing aliases);
4. the regressor: ``pinocchio.computeJointTorqueRegressor`` (10 standard parameters per link in
   pinocchio's order) plus, per joint, the rotor inertia ``Ia`` (q̈_j, where the case has it),
   viscous ``Fv`` (q̇_j) and Coulomb ``Fc`` (sign q̇_j) columns, as physid's models have them,
   and where the case's friction is asymmetric (Fc+ ≠ −Fc−) a constant ``OF`` (1) per joint:
   Fc sign q̇ + OF equals Fc+ for q̇ > 0 and Fc− for q̇ < 0;
5. base columns: QR with column pivoting of that regressor stacked over 300 random states; the
   dependent columns regroup into the base ones, β_base = β[base] + K β[dep], K = R11⁻¹ R12;
6. ordinary least squares (``np.linalg.lstsq``) on the stacked rows; standard errors
   σ̂² (WᵀW)⁻¹ with σ̂² = RSS / (N − p) (white-noise form, used only to flag well-excited
   parameters);
7. prediction τ̂ = W β̂ on another record built the same way.

``parallel=True`` is the variant with parallel filtering (Gautier): the regressor is computed at
every sample and its columns go through the same Butterworth as τ before the decimation, so that
the nonlinear columns (sign q̇ of Coulomb friction) are filtered like the torque they explain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.linalg import qr
from scipy.signal import butter, filtfilt

STANDARD = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")


@dataclass
class Rows:
    """Filtered, differentiated, decimated samples of one record."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray  # the measured torque through the same filter
    W: np.ndarray  # the base regressor at the kept samples (n, nj, n_base)


@dataclass
class RecipeFit:
    beta: np.ndarray  # base parameters, in `Recipe.base_names` order
    stderr: np.ndarray
    cutoff_hz: float
    decimate: int
    n_rows: int
    condition_number: float


class Recipe:
    """The recipe for one robot (URDF), with or without a rotor-inertia column per joint."""

    def __init__(self, urdf, *, armature=False, offset=False, parallel=False, n_random=300, seed=0):
        self.parallel = parallel
        self.offset = offset
        self.model = pin.buildModelFromUrdf(str(urdf))
        self.data = self.model.createData()
        self.nj = nj = self.model.nv
        self.armature = armature
        names = [f"{p}{j + 1}" for j in range(nj) for p in STANDARD]
        drive = (["Ia"] if armature else []) + ["Fv", "Fc"] + (["OF"] if offset else [])
        names += [f"{d}{j + 1}" for d in drive for j in range(nj)]
        self.column_names = tuple(names)
        rng = np.random.default_rng(seed)
        S = n_random
        Y = self.regressor(
            rng.uniform(-np.pi, np.pi, (S, nj)),
            rng.uniform(-3, 3, (S, nj)),
            rng.uniform(-10, 10, (S, nj)),
        ).reshape(S * nj, -1)
        _, R, P = qr(Y, mode="economic", pivoting=True)
        d = np.abs(np.diag(R))
        rank = int(np.sum(d > 1e-9 * d[0]))
        self.base = P[:rank]
        self.dependent = P[rank:]
        self.K = np.linalg.solve(R[:rank, :rank], R[:rank, rank:])
        regrouped = np.any(np.abs(self.K) > 1e-9, axis=1)
        order = np.argsort(self.base)  # base parameters in the order of the columns
        self.base, self.K, regrouped = self.base[order], self.K[order], regrouped[order]
        self.base_names = tuple(
            names[c] + ("R" if g else "") for c, g in zip(self.base, regrouped, strict=True)
        )

    @property
    def n_base(self) -> int:
        return self.base.size

    # ------------------------------------------------------------------ regressors
    def regressor(self, q, qd, qdd) -> np.ndarray:
        """Full regressor (n, nj, 10 nj + drive columns)."""
        n, nj = q.shape
        Y = np.empty((n, nj, len(self.column_names)))
        for k in range(n):
            Y[k, :, : 10 * nj] = pin.computeJointTorqueRegressor(
                self.model, self.data, q[k], qd[k], qdd[k]
            )
        c = 10 * nj
        eye = np.eye(nj)
        if self.armature:
            Y[:, :, c : c + nj] = qdd[:, None, :] * eye
            c += nj
        Y[:, :, c : c + nj] = qd[:, None, :] * eye
        Y[:, :, c + nj : c + 2 * nj] = np.sign(qd)[:, None, :] * eye
        if self.offset:
            Y[:, :, c + 2 * nj : c + 3 * nj] = eye
        return Y

    def base_regressor(self, q, qd, qdd) -> np.ndarray:
        return self.regressor(q, qd, qdd)[:, :, self.base]

    def truth(self, truth) -> np.ndarray:
        """The base parameters of a `cases.Truth` (standard parameters in pinocchio's order)."""
        beta = list(np.asarray(truth.standard, float).ravel())
        if self.armature:
            beta += list(truth.armature)
        beta += list(truth.viscous) + list(truth.coulomb)
        if self.offset:
            beta += list(truth.offset if truth.offset is not None else np.zeros(self.nj))
        beta = np.asarray(beta)
        return beta[self.base] + self.K @ beta[self.dependent]

    # ------------------------------------------------------------------ the pipeline
    def rows(self, rec, cutoff_hz) -> Rows:
        """Steps 1–3 on a record with ``q1..qn``, ``tau1..taun`` (uniformly sampled)."""
        nj = self.nj
        t = np.asarray(rec.t)
        dt = float(np.median(np.diff(t)))
        fs = 1.0 / dt
        q = np.asarray(rec.select([f"q{j + 1}" for j in range(nj)]))
        tau = np.asarray(rec.select([f"tau{j + 1}" for j in range(nj)]))
        b, a = butter(4, min(cutoff_hz / (fs / 2), 0.8))
        qf = filtfilt(b, a, q, axis=0)
        tf = filtfilt(b, a, tau, axis=0)
        qd = np.gradient(qf, dt, axis=0)
        qdd = np.gradient(qd, dt, axis=0)
        nd = max(1, int(fs / (5 * cutoff_hz)))
        edge = int(np.ceil(3.0 / cutoff_hz / dt))
        sel = np.arange(edge, t.size - edge, nd)
        self.decimate_ = nd
        if self.parallel:  # the regressor at every sample through the same filter
            W = filtfilt(b, a, self.base_regressor(qf, qd, qdd), axis=0)[sel]
        else:
            W = self.base_regressor(qf[sel], qd[sel], qdd[sel])
        return Rows(t[sel], qf[sel], qd[sel], qdd[sel], tf[sel], W)

    def filtered_torque(self, rec, cutoff_hz) -> np.ndarray:
        """The measured torque of a whole record through the recipe's filter."""
        t = np.asarray(rec.t)
        dt = float(np.median(np.diff(t)))
        b, a = butter(4, min(cutoff_hz * 2 * dt, 0.8))
        tau = np.asarray(rec.select([f"tau{j + 1}" for j in range(self.nj)]))
        return filtfilt(b, a, tau, axis=0)

    def fit(self, rec, cutoff_hz, span=None) -> RecipeFit:
        """OLS on the rows of ``rec``; ``span = (t0, t1)`` [s] keeps only the rows in it (to
        compare with another method on the time its rows cover)."""
        r = self.rows(rec, cutoff_hz)
        keep = slice(None) if span is None else (r.t >= span[0]) & (r.t <= span[1])
        W = r.W[keep].reshape(-1, self.n_base)
        y = r.tau[keep].ravel()
        beta, *_ = np.linalg.lstsq(W, y, rcond=None)
        dof = max(1, W.shape[0] - W.shape[1])
        s2 = float(np.sum((W @ beta - y) ** 2) / dof)
        cov = s2 * np.linalg.pinv(W.T @ W)
        scale = np.linalg.norm(W, axis=0)
        cond = float(np.linalg.cond(W / np.where(scale > 0, scale, 1.0)))
        return RecipeFit(
            beta, np.sqrt(np.diag(cov)), cutoff_hz, self.decimate_, len(y) // self.nj, cond
        )

    def predict(self, fit: RecipeFit, rec):
        """τ̂ on the held-out record's rows: (t, τ̂, τ filtered) at the kept samples."""
        r = self.rows(rec, fit.cutoff_hz)
        tau_hat = r.W @ fit.beta
        return r.t, tau_hat, r.tau

    # ------------------------------------------------------------------ other estimates
    def from_torque_model(self, torque_fn, n=200, seed=7):
        """The recipe's base parameters of any model given as a function of the state:
        ``torque_fn(q, qd, qdd) -> (n, nj)``, fitted on random states (exact when the model is
        a set of base parameters of the same robot). Returns (β_base, relative residual)."""
        rng = np.random.default_rng(seed)
        nj = self.nj
        q = rng.uniform(-np.pi, np.pi, (n, nj))
        qd = rng.uniform(-3, 3, (n, nj))
        qdd = rng.uniform(-10, 10, (n, nj))
        W = self.base_regressor(q, qd, qdd).reshape(-1, self.n_base)
        tau = np.asarray(torque_fn(q, qd, qdd)).ravel()
        beta, *_ = np.linalg.lstsq(W, tau, rcond=None)
        return beta, float(np.linalg.norm(W @ beta - tau) / np.linalg.norm(tau))


def relative_error(pred, target):
    """Overall ‖τ̂ − τ‖/‖τ‖ and per joint rms(τ̂_j − τ_j)/rms(τ_j)."""
    e = pred - target
    per = np.sqrt(np.mean(e**2, axis=0)) / np.sqrt(np.mean(target**2, axis=0))
    return float(np.linalg.norm(e) / np.linalg.norm(target)), per


def well_excited(fit: RecipeFit, truth_base, limit=0.10):
    """Base parameters with a nonzero truth and a relative standard error below ``limit`` in
    the recipe's own fit: the set on which every method's parameter error is averaged."""
    scale = np.abs(truth_base)
    ok = scale > 1e-9 * max(1.0, scale.max())
    rse = np.full(scale.shape, np.inf)
    rse[ok] = fit.stderr[ok] / scale[ok]
    return rse < limit


def parameter_error(beta, truth_base, mask):
    if not mask.any():
        return float("nan")
    return float(np.mean(np.abs(beta[mask] - truth_base[mask]) / np.abs(truth_base[mask])))
