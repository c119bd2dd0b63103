"""The linear-in-parameters form τ = Y(q, q̇, q̈) β(θ) of a chain and its base parameters.

`_LinearInParameters` holds the methods of `physid.models.chain.ChainModel` that work on the
regressor Y and the monomials β: derived on first use (then cached on disk like the rest of the
model). It relies on the model's ``_spec``, ``_regressor``, ``_cache_enabled``, ``cache_key``,
``n_joints``, ``parameter_names``, `parameter_vector` and ``_states``.
"""

from __future__ import annotations

import numpy as np

from ..errors import IdentifiabilityError
from . import _cache
from .chain_base import BaseParameters, _format_combination
from .chain_derive import _derive_regressor, _with_progress
from .codegen import source_to_function


class _LinearInParameters:
    """Regressor, monomials and base parameters of a chain model (a base of `ChainModel`)."""

    # -- linear-in-parameters form ----------------------------------------------------------
    def _regressor_data(self) -> dict:
        if isinstance(self._regressor, IdentifiabilityError):
            raise self._regressor
        if self._regressor is None:
            try:
                data, _ = _cache.cached(
                    "regressor",
                    self.cache_key,
                    lambda: _with_progress(
                        self._spec,
                        lambda: _derive_regressor(self._spec),
                        what="regressor (linear-in-parameters form)",
                    ),
                    enabled=self._cache_enabled,
                    valid=lambda d: {"monomials", "names", "keep", "source"} <= set(d),
                )
            except IdentifiabilityError as exc:
                self._regressor = exc  # remembered: the derivation is not repeated
                raise
            data = dict(data)
            data["function"] = source_to_function(data["source"], "regressor")
            keep = data["keep"]
            data["exponents"] = np.array([data["monomials"][b] for b in keep], dtype=float).reshape(
                len(keep), len(self.parameter_names)
            )
            self._regressor = data
        return self._regressor

    @property
    def beta_names(self) -> tuple:
        """Names of the monomials β(θ) of the linear-in-parameters form, e.g. ``"m2*l2**2"``."""
        d = self._regressor_data()
        return tuple(d["names"][b] for b in d["keep"])

    def beta(self, params=None) -> np.ndarray:
        """β(θ): the monomial values, shape (n_beta,), so that τ = regressor(q, q̇, q̈) @ β.

        Parameters
        ----------
        params : dict or array_like (n_parameters,), optional
            As in `parameter_vector`.

        Returns
        -------
        ndarray, shape (n_beta,) [SI units of each monomial, e.g. kg·m² for ``m2*l2**2``]
        """
        theta = self.parameter_vector(params)
        E = self._regressor_data()["exponents"]
        return np.prod(theta[None, :] ** E, axis=1)

    def beta_jacobian(self, params=None) -> np.ndarray:
        """∂β/∂θ, shape (n_beta, n_parameters), at ``params`` (nominal by default).

        Parameters
        ----------
        params : dict or array_like (n_parameters,), optional
            As in `parameter_vector`.

        Returns
        -------
        ndarray, shape (n_beta, n_parameters) [unit of β_b per unit of θ_j]
        """
        theta = self.parameter_vector(params)
        E = self._regressor_data()["exponents"]
        out = np.zeros_like(E)
        for j in range(theta.size):
            Ej = E.copy()
            Ej[:, j] -= 1  # ∂(θ_j^e)/∂θ_j = e θ_j^(e−1)
            with np.errstate(divide="ignore", invalid="ignore"):
                val = E[:, j] * np.prod(
                    np.where(Ej < 0, 1.0, theta[None, :] ** np.maximum(Ej, 0)), axis=1
                )
            out[:, j] = np.where(E[:, j] > 0, val, 0.0)
        return out

    def regressor(self, q, qd, qdd) -> np.ndarray:
        """Y(q, q̇, q̈), shape (n_samples, n_joints, n_beta), with τ = Y @ beta(params).

        Derived on first use (then cached on disk like the rest of the model).

        Parameters
        ----------
        q, qd, qdd : array_like, shape (n_samples, n_joints)
            Joint angles [rad], rates [rad/s] and accelerations [rad/s²].

        Returns
        -------
        ndarray, shape (n_samples, n_joints, n_beta) [N·m per unit of each monomial]
            Column b multiplies the monomial `beta_names` [b] of the parameters.

        Raises
        ------
        IdentifiabilityError
            The model is not polynomial in its parameters (no linear-in-parameters form).

        Examples
        --------
        >>> import numpy as np, physid
        >>> model = physid.load_model("manipulator")
        >>> q, qd, qdd = np.random.default_rng(2).normal(size=(3, 6, 4))
        >>> tau = model.regressor(q, qd, qdd) @ model.beta()
        >>> bool(np.allclose(tau, model.inverse_dynamics(q, qd, qdd)))
        True
        """
        self._regressor_data()
        n, cols = self._states((q, "q"), (qd, "qd"), (qdd, "qdd"))
        return self._regressor_eval(cols, n)

    def _regressor_eval(self, cols, n) -> np.ndarray:
        d = self._regressor_data()
        n_all = len(d["monomials"])
        Y = d["function"](*cols, n).reshape(self.n_joints, n_all, n)[:, d["keep"], :]
        return Y.transpose(2, 0, 1).copy()

    def base_parameters(
        self, params=None, *, n_states: int | None = None, seed: int = 0, rtol: float | None = None
    ) -> BaseParameters:
        """Identifiable combinations of the parameters (base parameters).

        The regressor Y is evaluated at random states (q uniform in [−π, π], q̇, q̈ standard
        normal), its columns scaled to unit norm, and factorised by QR with column pivoting; the
        numerical rank is the number of base parameters, each dependent column is expressed in the
        independent ones (base = β_ind + K β_dep). Then, symbolically, parameters that enter τ only
        through one common monomial are reported (e.g. "m1 and l1 enter only as m1*l1**2"), and
        the rank of ∂base/∂θ at ``params`` (nominal by default) says how many directions of θ are
        determined.

        Parameters
        ----------
        params : dict or array_like, optional
            Where to evaluate ∂base/∂θ (nominal values by default).
        n_states : int, optional
            Random states used (default max(30, 3·n_beta)).
        seed : int
            Seed of the random states.
        rtol : float, optional
            Rank threshold on |R_ii| / |R_00| (default `physid.models.base.RANK_RTOL`).
        """
        import scipy.linalg

        from .base import RANK_RTOL, regrouping

        rtol = RANK_RTOL if rtol is None else rtol

        d = self._regressor_data()
        names = self.beta_names
        nb = len(names)
        ns = n_states or max(30, 3 * nb)
        rng = np.random.default_rng(seed)
        nj = self.n_joints
        q = rng.uniform(-np.pi, np.pi, (ns, nj))
        Y = self.regressor(q, rng.normal(size=(ns, nj)), rng.normal(size=(ns, nj))).reshape(
            ns * nj, nb
        )
        norms = np.linalg.norm(Y, axis=0)
        Ys = Y / np.where(norms > 0, norms, 1.0)
        _, R, perm = scipy.linalg.qr(Ys, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        rank = int(np.sum(diag > rtol * diag[0])) if diag.size else 0
        ind, dep = perm[:rank], perm[rank:]
        K = np.zeros((rank, nb))
        K[np.arange(rank), ind] = 1.0
        if dep.size:
            # W_dep = W_ind C (exact, or to within rtol), so τ = W_ind (β_ind + C β_dep)
            C = regrouping(Y, ind, dep, rtol)
            C[np.abs(C) < 1e-10] = 0.0
            K[:, dep] = C
        order = np.argsort(ind)  # list base parameters in β order
        K = K[order]
        ind_sorted = ind[order]
        base_names = tuple(_format_combination(K[k], names) for k in range(rank))
        # θ-level: every unidentifiable direction named by the one Combination path
        # (physid.models.identifiability.describe_direction), as every result names it
        from .identifiability import Combination, describe_direction

        E = d["exponents"]
        pnames = self.parameter_names
        combos = []
        for j in range(len(pnames)):
            if not np.any(E[:, j] > 0):
                text = (
                    f"{pnames[j]} does not enter the equations of motion: it cannot be identified"
                )
                combos.append(Combination((pnames[j],), f"{pnames[j]} (no effect)", {}, text))
        theta = self.parameter_vector(params)
        Jb = K @ self.beta_jacobian(theta) * theta[None, :]  # relative (dθ/θ) coordinates
        if Jb.size:
            _, s, Vt = np.linalg.svd(Jb)
            trank = int(np.sum(s > 1e-9 * s[0])) if s.size and s[0] > 0 else 0
            null = Vt[trank:].T
        else:
            trank, null = 0, np.eye(len(pnames))
        silent = {c.parameters[0] for c in combos}
        for v in null.T:
            if not np.any(np.abs(v) > 1e-6):
                continue
            c = describe_direction(v, pnames, beta_names=names)
            if not set(c.parameters) <= silent:
                combos.append(c)
        statements = [c.text for c in combos]
        no_effect = tuple(d["names"][b] for b in range(len(d["monomials"])) if b not in d["keep"])
        return BaseParameters(
            beta_names=names,
            n_beta=nb,
            n_base=rank,
            base_names=base_names,
            base_matrix=K,
            independent=tuple(names[b] for b in ind_sorted),
            no_effect=no_effect,
            parameter_names=pnames,
            theta_rank=trank,
            unidentifiable=tuple(statements),
            null_directions=null,
            combinations=tuple(combos),
        )
