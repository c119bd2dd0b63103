"""Lumped-parameter structures: M q̈ + C q̇ + K q + f_nl(q, q̇) = B u, in physical parameters.

A `StructureModel` is built from a ``kind = "structure"`` model file (`physid.models.
spec_structure`): masses on named nodes, springs and dampers between nodes (or the ground),
forces on nodes, bases moved by a measured displacement x_b (the right-hand side then has
K_b x_b + C_b ẋ_b from the springs and dampers that join them) and measured outputs
(displacement, velocity or acceleration of a node); or the
matrices M, C, K written as expressions. Nonlinear terms: a cubic spring k3·d³ (d the
elongation, the Duffing spring) and Coulomb friction Fc·sign(q̇_i) on a node.

What is here (numbers only; the expressions are parsed by `physid.expressions`, never run as
Python):

* the matrices M, C, K, the input matrix B and the first-order form ẋ = A x + B_s u,
  y = C_s x + D_s u (x = [q, q̇]);
* the equation-error regression: every term is linear in the parameters when each expression is
  (checked symbolically once), so M q̈ + C q̇ + K q + f_nl = B u reads Φ(q, q̇, q̈) θ = B u − φ₀;
* `StructureModel.identifiability`: the rank of ∂h/∂log θ, h the Markov parameters
  C_s A^k B_s (k < 2·2n), which fix the transfer function; bounded time, no symbolic solving;
* `StructureModel.modal`: natural frequencies, damping ratios and mode shapes from the
  eigenvalues of A, with delta-method standard errors (`ModalParameters`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import IdentifiabilityError, InputError, ModelFileError, PhysidError, arg
from .spec_structure import GROUND, StructureSpec
from .structure_results import ModalParameters, StructureIdentifiability

__all__ = ["StructureModel", "ModalParameters", "StructureIdentifiability"]

#: Velocity scale v_ε [m/s] of the regularised Coulomb law Fc·tanh(q̇/v_ε) used in simulation.
FRICTION_VELOCITY = 1e-4

_UNIT = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


@dataclass(frozen=True)
class _Term:
    """One expression's contribution ``sign · e(θ)`` at (row, col) of a matrix (or a node pair)."""

    row: int
    col: int
    sign: float
    text: str


@dataclass(frozen=True, eq=False)
class StructureModel:
    """A lumped-parameter structure M q̈ + C q̇ + K q + f_nl = B u (see the module docstring).

    Build it with `physid.load_model` on a ``kind = "structure"`` file, or `from_spec`.

    Attributes
    ----------
    name : str
        Model name.
    nodes : tuple of str
        The coordinates q [m], in order.
    parameter_names : tuple of str
        The parameters θ.
    parameters : dict
        name -> nominal value (SI).
    unknown : tuple of str
        The parameters estimated by default (``identify = true``).
    input_names, output_names : tuple of str
        Recording channels of the forces [N] and of the measured outputs.
    outputs : tuple of (quantity, node)
        What each output measures.
    units : dict
        name -> unit of each parameter and channel.
    linear_in_parameters : bool
        Every expression is affine in θ (the equation-error regression applies).
    nonlinear : bool
        The model has cubic springs or Coulomb friction.
    """

    name: str
    nodes: tuple
    parameter_names: tuple
    _nominal: dict
    unknown: tuple
    input_names: tuple
    output_names: tuple
    outputs: tuple
    units: dict
    _terms: dict = field(repr=False)
    _affine: dict | None = field(repr=False)
    source: str = ""
    description: str = ""
    recording: tuple = ()

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_spec(cls, spec: StructureSpec) -> StructureModel:
        """Build the model from a parsed file; checks M at the nominal values.

        Parameters
        ----------
        spec : StructureSpec
            From `physid.models.spec.parse_model_text`.

        Returns
        -------
        StructureModel

        Raises
        ------
        ModelFileError
            A mass that is not positive, or a matrix M that is singular or not symmetric
            positive definite at the nominal values (naming the element).
        """
        index = {n: i for i, n in enumerate(spec.nodes)}
        index.update({b[0]: len(spec.nodes) + j for j, b in enumerate(spec.bases)})
        terms = _collect_terms(spec, index)
        names = spec.parameter_names
        nominal = {p.name: p.value for p in spec.parameters}
        units = {p.name: p.unit for p in spec.parameters}
        units.update({c: "N" for _, c, _ in spec.forces})
        units.update({c: "m" for _, c, _ in spec.bases})
        units.update({o.channel: _UNIT[o.quantity] for o in spec.outputs})
        model = cls(
            name=spec.name,
            nodes=spec.nodes,
            parameter_names=names,
            _nominal=nominal,
            unknown=tuple(p.name for p in spec.parameters if p.identify),
            input_names=tuple(c for _, c, _ in (*spec.forces, *spec.bases)),
            output_names=tuple(o.channel for o in spec.outputs),
            outputs=tuple((o.quantity, index[o.node]) for o in spec.outputs),
            units=units,
            _terms=terms,
            _affine=_affine_terms(terms, names),
            source=spec.source,
            description=spec.description,
            recording=spec.recording,
        )
        object.__setattr__(model, "_force_nodes", tuple(index[f[0]] for f in spec.forces))
        object.__setattr__(model, "base_nodes", tuple(b[0] for b in spec.bases))
        _check_mass(model, spec)
        return model

    # ------------------------------------------------------------------ parameters
    @property
    def parameters(self) -> dict:
        """name -> nominal value (SI)."""
        return dict(self._nominal)

    @property
    def n(self) -> int:
        """Number of coordinates (nodes)."""
        return len(self.nodes)

    @property
    def force_names(self) -> tuple:
        """Channels of the forces [N] (the first entries of ``input_names``)."""
        return self.input_names[: len(self._force_nodes)]

    @property
    def base_names(self) -> tuple:
        """Channels of the measured base displacements [m] (the last entries of
        ``input_names``), one per entry of ``base_nodes``."""
        return self.input_names[len(self._force_nodes) :]

    @property
    def linear_in_parameters(self) -> bool:
        return self._affine is not None

    @property
    def nonlinear(self) -> bool:
        return bool(self._terms["cubic"] or self._terms["friction"])

    @property
    def nonlinear_names(self) -> tuple:
        """Parameters that enter only the cubic springs and friction."""
        from ..expressions import expression_names

        lin = set()
        for key in ("M", "C", "K"):
            for t in self._terms[key]:
                lin |= set(expression_names(t.text)[0])
        nl = set()
        for key in ("cubic", "friction"):
            for t in self._terms[key]:
                nl |= set(expression_names(t.text)[0])
        return tuple(p for p in self.parameter_names if p in nl - lin)

    def values(self, params=None) -> dict:
        """Every parameter's value: the nominal ones overridden by ``params``.

        Parameters
        ----------
        params : mapping, optional
            name -> value (SI); unknown names are refused.

        Returns
        -------
        dict
        """
        out = dict(self._nominal)
        if params is None:
            return out
        bad = [k for k in params if k not in out]
        if bad:
            raise InputError(
                f"{arg('params')} has unknown parameter(s) {bad}; the model's are "
                f"{list(self.parameter_names)}."
            )
        out.update({k: float(v) for k, v in params.items()})
        return out

    def _eval(self, terms, vals, shape) -> np.ndarray:
        out = np.zeros(shape)
        if self._affine is not None:
            theta = np.array([vals[p] for p in self.parameter_names])
            for t, (c0, g) in zip(terms, self._affine_for(terms), strict=True):
                out[t.row, t.col] += t.sign * (c0 + g @ theta)
            return out
        from ..expressions import evaluate_expression

        for t in terms:
            out[t.row, t.col] += t.sign * float(evaluate_expression(t.text, vals))
        return out

    def _affine_for(self, terms):
        return [self._affine[t.text] for t in terms]

    def matrices(self, params=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """M [kg], C [N·s/m], K [N/m] at the given parameter values.

        Parameters
        ----------
        params : mapping, optional
            Overrides of the nominal values.

        Returns
        -------
        M, C, K : ndarray, shape (n, n)
        """
        vals = self.values(params)
        n = self.n
        M = self._eval(self._terms["M"], vals, (n, n))
        return M, *(self._lhs(k, vals)[:, :n] for k in ("C", "K"))

    def _lhs(self, key, vals) -> np.ndarray:
        """C or K on the left-hand side with the base columns: shape (n, n + n_bases)."""
        return self._eval(self._terms[key], vals, (self.n, self.n + len(self.base_nodes)))

    def base_matrices(self, params=None) -> tuple[np.ndarray, np.ndarray]:
        """C_b [N·s/m] and K_b [N/m] of M q̈ + C q̇ + K q = B u + K_b x_b + C_b ẋ_b.

        A spring k (damper c) between base j and node i puts +k (+c) at (i, j): the force
        k (x_b − q_i) on node i, of which −k q_i is in K. Empty (n, 0) without base motions.

        Parameters
        ----------
        params : mapping, optional
            Overrides of the nominal values.

        Returns
        -------
        Cb, Kb : ndarray, shape (n, n_bases)
        """
        vals = self.values(params)
        return tuple(0.0 - self._lhs(k, vals)[:, self.n :] for k in ("C", "K"))

    def velocity_feedthrough(self, params=None) -> np.ndarray:
        """P, shape (n, n_inputs), with q̇ = v + P u for the state x = [q, v] of `state_space`.

        P = M⁻¹ C_b in the base columns (a damper to a moving base makes the velocity jump
        with the base's), 0 in the force columns.

        Parameters
        ----------
        params : mapping, optional

        Returns
        -------
        ndarray (n, n_inputs)
        """
        M = self.matrices(params)[0]
        Cb = self.base_matrices(params)[0]
        P = np.zeros((self.n, len(self.input_names)))
        P[:, len(self._force_nodes) :] = np.linalg.solve(M, Cb)
        return P

    @property
    def input_matrix(self) -> np.ndarray:
        """B, shape (n, n_forces): force j acts on node ``_force_nodes[j]``."""
        nf = len(self._force_nodes)
        b = np.zeros((self.n, nf))
        b[list(self._force_nodes), np.arange(nf)] = 1.0
        return b

    def nonlinear_forces(self, q, qd, params=None, *, smooth: float | None = None) -> np.ndarray:
        """f_nl(q, q̇): cubic springs and Coulomb friction [N], shape (n_samples, n).

        Parameters
        ----------
        q, qd : ndarray, shape (n_samples, n) [m, m/s]
        params : mapping, optional
        smooth : float [m/s], optional
            Friction as Fc·tanh(q̇/smooth) (for integrators); exact sign(q̇) when None.

        Returns
        -------
        ndarray, shape (n_samples, n)
        """
        vals = self.values(params)
        q = np.atleast_2d(q)
        out = np.zeros(q.shape)
        from ..expressions import evaluate_expression

        for t in self._terms["cubic"]:  # row = node a (-1: ground), col = node b
            k3 = float(evaluate_expression(t.text, vals))
            d = _elongation(q, t.row, t.col)
            if t.col >= 0:
                out[:, t.col] += k3 * d**3
            if t.row >= 0:
                out[:, t.row] -= k3 * d**3
        for t in self._terms["friction"]:
            fc = float(evaluate_expression(t.text, vals))
            v = np.atleast_2d(qd)[:, t.row]
            out[:, t.row] += fc * (np.sign(v) if smooth is None else np.tanh(v / smooth))
        return out

    def nonlinear_terms(self, params=None) -> tuple[list, list]:
        """The nonlinear terms as numbers: [(node a, node b, k3)] (−1: ground) and
        [(node, Fc)].

        Parameters
        ----------
        params : mapping, optional

        Returns
        -------
        cubic, friction : list of tuple
        """
        from ..expressions import evaluate_expression

        vals = self.values(params)
        cubic = [
            (t.row, t.col, float(evaluate_expression(t.text, vals))) for t in self._terms["cubic"]
        ]
        friction = [
            (t.row, float(evaluate_expression(t.text, vals))) for t in self._terms["friction"]
        ]
        return cubic, friction

    def state_space(self, params=None):
        """The linear part as ẋ = A x + B_s u, y = C_s x + D_s u with x = [q, v].

        u = [forces, base displacements x_b]. v = q̇ − P x_b with P = M⁻¹ C_b
        (`velocity_feedthrough`), so that the base's velocity never appears:
        q̇ = v + P x_b, M v̇ = B u_F + (K_b − C P) x_b − C v − K q, whose transfer function is
        (M s² + C s + K)⁻¹ (B u_F + (K_b + C_b s) x_b). Without a damper on a base, v = q̇.

        Parameters
        ----------
        params : mapping, optional

        Returns
        -------
        A : ndarray (2n, 2n)
        Bs : ndarray (2n, n_inputs)
        Cs : ndarray (n_outputs, 2n)
        Ds : ndarray (n_outputs, n_inputs)
        """
        M, C, K = self.matrices(params)
        Cb, Kb = self.base_matrices(params)
        n = self.n
        MinvKC = np.linalg.solve(M, np.hstack([K, C, self.input_matrix, Cb]))
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -MinvKC[:, :n]
        A[n:, n:] = -MinvKC[:, n : 2 * n]
        nf = self.input_matrix.shape[1]
        P = MinvKC[:, 2 * n + nf :]
        forced = np.vstack([np.zeros((n, nf)), MinvKC[:, 2 * n : 2 * n + nf]])
        based = np.vstack([P, np.linalg.solve(M, Kb - C @ P)])
        Bs = np.hstack([forced, based])
        Pu = np.hstack([np.zeros((n, nf)), P])
        Cs = np.zeros((len(self.outputs), 2 * n))
        Ds = np.zeros((len(self.outputs), Bs.shape[1]))
        for r, (quantity, i) in enumerate(self.outputs):
            if quantity == "displacement":
                Cs[r, i] = 1.0
            elif quantity == "velocity":
                Cs[r, n + i] = 1.0
                Ds[r] = Pu[i]
            else:  # a damper on a base would put ẋ_b into q̈ (refused in the model file)  # q̈ = M⁻¹(B u − K q − C q̇): row i of the lower half of A, B_s
                Cs[r] = A[n + i]
                Ds[r] = Bs[n + i]
        return A, Bs, Cs, Ds

    # ------------------------------------------------------------------ regression
    def regression(self, q, qd, qdd, unknown=None, params=None, *, cubes=None, signs=None):
        """The equation-error form Φ θ_u = B u − φ₀ of M q̈ + C q̇ + K q + f_nl = B u.

        Parameters
        ----------
        q, qd, qdd : ndarray, shape (n_samples, n) [m, m/s, m/s²]
            (Filtered) displacements and derivatives of every node; with base motions, ``q``
            and ``qd`` have n + n_bases columns, the bases' x_b and ẋ_b after the nodes (their
            springs and dampers are then columns of Φ, the −K_b x_b − C_b ẋ_b of the
            left-hand side).
        unknown : sequence of str, optional
            The columns of Φ (default `unknown`); the others are held at ``params``.
        params : mapping, optional
            Values of the held parameters.
        cubes : ndarray, shape (n_samples, n_cubic), optional
            d³ of each cubic spring (filtered like the other columns); default from ``q``.
        signs : ndarray, shape (n_samples, n_friction), optional
            sign(q̇) of each friction term; default from ``qd``.

        Returns
        -------
        Phi : ndarray, shape (n_samples, n, n_unknown)
        phi0 : ndarray, shape (n_samples, n)
            The held parameters' and constant part of the left-hand side.

        Raises
        ------
        EstimationError
            An expression is not affine in the parameters (use output-error).
        """
        from ..errors import EstimationError

        if self._affine is None:
            raise EstimationError(
                f"model {self.name!r} has expressions that are not linear in its parameters; "
                "equation-error regresses on parameters that enter linearly. Use "
                f"{arg('method', 'output-error')}."
            )
        unknown = tuple(self.unknown if unknown is None else unknown)
        vals = self.values(params)
        theta = np.array([vals[p] for p in self.parameter_names])
        col = np.array([self.parameter_names.index(u) for u in unknown], dtype=int)
        held = np.ones(len(theta), bool)
        held[col] = False
        ns = np.asarray(q).shape[0]
        Phi = np.zeros((ns, self.n, len(unknown)))
        phi0 = np.zeros((ns, self.n))
        cubes = _cubes(q, self._terms["cubic"]) if cubes is None else cubes
        if signs is None:
            signs = np.sign(np.asarray(qd)[:, [t.row for t in self._terms["friction"]]])
        columns = (
            [(t, qdd[:, t.col]) for t in self._terms["M"]]
            + [(t, qd[:, t.col]) for t in self._terms["C"]]
            + [(t, q[:, t.col]) for t in self._terms["K"]]
        )
        for t, x in columns:
            c0, g = self._affine[t.text]
            Phi[:, t.row, :] += t.sign * x[:, None] * g[col]
            phi0[:, t.row] += t.sign * x * (c0 + g[held] @ theta[held])
        for j, t in enumerate(self._terms["cubic"]):
            c0, g = self._affine[t.text]
            for node, s in ((t.col, 1.0), (t.row, -1.0)):
                if node >= 0:
                    Phi[:, node, :] += s * cubes[:, j, None] * g[col]
                    phi0[:, node] += s * cubes[:, j] * (c0 + g[held] @ theta[held])
        for j, t in enumerate(self._terms["friction"]):
            c0, g = self._affine[t.text]
            Phi[:, t.row, :] += signs[:, j, None] * g[col]
            phi0[:, t.row] += signs[:, j] * (c0 + g[held] @ theta[held])
        return Phi, phi0

    def cubic_elongations(self, q) -> np.ndarray:
        """d = q_b − q_a of each cubic spring, shape (n_samples, n_cubic) [m]."""
        q = np.atleast_2d(q)
        return np.column_stack(
            [_elongation(q, t.row, t.col) for t in self._terms["cubic"]] or [np.zeros(len(q))]
        )[:, : len(self._terms["cubic"])]

    @property
    def friction_nodes(self) -> tuple:
        """Node index of each Coulomb friction term."""
        return tuple(t.row for t in self._terms["friction"])

    # ------------------------------------------------------------------ analysis
    def identifiability(self, unknown=None, *, points: int = 3, seed: int = 0):
        """Structural identifiability of the linear parameters from the inputs and outputs.

        The transfer function from the forces to the outputs is fixed by the Markov parameters
        h_k = C_s A^k B_s (k = 0 … 4n − 1; 2·(2n) determine a rational function of order 2n)
        and D_s. Its Jacobian J = ∂h/∂log θ is evaluated at ``points`` random parameter vectors
        around the nominal values (×e^{±0.5}) by central differences; the generic rank is the
        largest rank found. Rows are scaled by |h| so that the fast-growing high Markov
        parameters do not swamp the others. A parameter is unidentifiable when the null space
        of J has a component along it.

        Parameters
        ----------
        unknown : sequence of str, optional
            Parameters to check (default `unknown`).
        points : int
            Random points.
        seed : int
            Seed of the points.

        Returns
        -------
        StructureIdentifiability
        """
        start = time.perf_counter()
        unknown = tuple(self.unknown if unknown is None else unknown)
        nl = set(self.nonlinear_names)
        lin = [p for p in unknown if p not in nl]
        rng = np.random.default_rng(seed)
        best_rank, null = -1, None
        for _ in range(max(1, points)):
            base = {p: self._nominal[p] * np.exp(rng.uniform(-0.5, 0.5)) for p in lin}
            J = self._markov_jacobian(lin, base)
            s, vt = np.linalg.svd(J, full_matrices=True)[1:]
            rank = int(np.sum(s > s[0] * 1e-7)) if s.size and s[0] > 0 else 0
            if rank > best_rank:
                best_rank, null = rank, vt[rank:]
        ident, unident, directions = _verdict(lin, null)
        if not unident:
            message = (
                f"all {len(lin)} linear parameters ({', '.join(lin)}) are identifiable from "
                f"inputs {list(self.input_names)} and outputs {list(self.output_names)}"
                + (
                    " (the forces carry the scale)"
                    if self.force_names
                    else " (the parameters held fixed carry the scale)"
                )
            )
        else:
            message = (
                f"{', '.join(unident)} are not identifiable from inputs {list(self.input_names)} "
                f"and outputs {list(self.output_names)}: {'; '.join(directions)}. Measure "
                "another output or fix one of them (identify = false)"
            )
        if nl & set(unknown):
            message += (
                f"; {', '.join(sorted(nl & set(unknown)))} act only through the nonlinear terms "
                "and are determined when the data excite them"
            )
        return StructureIdentifiability(
            tuple(ident),
            tuple(unident),
            tuple(directions),
            best_rank,
            len(lin),
            tuple(p for p in unknown if p in nl),
            message + ".",
            time.perf_counter() - start,
        )

    def _markov_jacobian(self, names, base) -> np.ndarray:
        """∂(h/|h|)/∂log θ by central differences (step 1e-5 in log θ)."""

        def h(values):
            A, Bs, Cs, Ds = self.state_space(values)
            out = [Ds.ravel()]
            x = Bs
            for _ in range(2 * A.shape[0]):
                out.append((Cs @ x).ravel())
                x = A @ x
            return np.concatenate(out)

        h0 = h(base)
        scale = np.where(np.abs(h0) > 1e-300, np.abs(h0), 1.0)
        cols = []
        for p in names:
            up, dn = dict(base), dict(base)
            up[p] = base[p] * np.exp(1e-5)
            dn[p] = base[p] * np.exp(-1e-5)
            cols.append((h(up) - h(dn)) / 2e-5 / scale)
        return np.column_stack(cols) if cols else np.zeros((h0.size, 0))

    def modal(self, params=None, covariance=None, names=None) -> ModalParameters:
        """Natural frequencies, damping ratios and mode shapes (see `ModalParameters`).

        λ_j are the eigenvalues of A with Im λ > 0; ω_j = |λ_j|, ζ_j = −Re λ_j/|λ_j|. With a
        ``covariance`` of the parameters ``names``, the standard errors come from the delta
        method, J Σ Jᵀ, J by central differences in the parameters.

        Parameters
        ----------
        params : mapping, optional
            Parameter values (an identified result's).
        covariance : ndarray (p, p), optional
            Covariance of the parameters ``names``.
        names : sequence of str, optional
            Order of ``covariance`` (default `unknown`).

        Returns
        -------
        ModalParameters
        """
        vals = self.values(params)
        w, z, shapes, over = self._modes(vals)
        if covariance is None:
            return ModalParameters(w, z, shapes, self.nodes, overdamped=over)
        names = tuple(self.unknown if names is None else names)
        cov = np.asarray(covariance, dtype=float)
        if cov.shape != (len(names), len(names)):
            raise InputError(
                f"{arg('covariance')} must be {len(names)}×{len(names)} (one row per name "
                f"{list(names)}); got shape {cov.shape}."
            )
        cols = []
        for p in names:
            h = 1e-6 * max(abs(vals[p]), 1e-12)
            up, dn = dict(vals), dict(vals)
            up[p] += h
            dn[p] -= h
            a, b = self._modes(up), self._modes(dn)
            if a[0].shape != w.shape or b[0].shape != w.shape:
                raise IdentifiabilityError(
                    "a mode changes from oscillating to overdamped within the step of the "
                    "delta method; the modal standard errors are not defined here."
                )
            da = np.concatenate([a[0], a[1], a[2].real.ravel()])
            db = np.concatenate([b[0], b[1], b[2].real.ravel()])
            cols.append((da - db) / (2 * h))
        J = np.column_stack(cols)
        se = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", J, cov, J), 0.0))
        m = w.size
        return ModalParameters(
            w, z, shapes, self.nodes, se[:m], se[m : 2 * m], se[2 * m :].reshape(shapes.shape), over
        )

    def _modes(self, vals):
        A = self.state_space(vals)[0]
        lam, vec = np.linalg.eig(A)
        osc = lam.imag > 1e-12 * np.maximum(np.abs(lam), 1.0)
        over = int(np.sum(np.abs(lam.imag) <= 1e-12 * np.maximum(np.abs(lam), 1.0)))
        lam, vec = lam[osc], vec[: self.n, osc]
        order = np.argsort(np.abs(lam))
        lam, vec = lam[order], vec[:, order]
        w = np.abs(lam)
        z = -lam.real / w
        big = vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
        shapes = vec / big  # largest entry 1 (rotates proportional-damping shapes to real)
        return w, z, shapes, over

    def check_units(self, recording) -> None:
        """Refuse channels whose unit contradicts the model (a force not in N, a displacement
        not in m, …); channels without a unit are not checked.

        Parameters
        ----------
        recording : Recording

        Raises
        ------
        InputError
            Naming the channel, its unit and the one expected.
        """
        from ..units import parse_unit

        for name in (*self.input_names, *self.output_names):
            if name not in getattr(recording, "names", ()):
                continue
            unit = recording.unit(name) if hasattr(recording, "unit") else ""
            if not unit:
                continue
            try:
                got, want = parse_unit(unit), parse_unit(self.units[name])
            except PhysidError:
                continue
            if got.si != want.si:
                raise InputError(
                    f"channel {name!r} has unit {unit!r}, but model {self.name!r} wants "
                    f"{self.units[name]!r} there; convert it or fix the header."
                )


def _elongation(q, a, b):
    qa = q[:, a] if a >= 0 else 0.0
    qb = q[:, b] if b >= 0 else 0.0
    return qb - qa


def _cubes(q, terms) -> np.ndarray:
    q = np.atleast_2d(q)
    return np.column_stack([_elongation(q, t.row, t.col) ** 3 for t in terms] or [q[:, :0]])


def _collect_terms(spec: StructureSpec, index: dict) -> dict:
    """The matrices' entries as (row, col, sign, expression) terms; cubic springs as
    (node a, node b) pairs with −1 for the ground; friction per node."""
    terms = {"M": [], "C": [], "K": [], "cubic": [], "friction": []}
    if spec.matrices:
        for key, rows in spec.matrices:
            for i, r in enumerate(rows):
                for j, text in enumerate(r):
                    if text.strip() not in ("0", "0.0"):
                        terms[key].append(_Term(i, j, 1.0, text))
        return {k: tuple(v) for k, v in terms.items()}
    for m in spec.masses:
        i = index[m.nodes[0]]
        terms["M"].append(_Term(i, i, 1.0, m.value))
        if m.extra:
            terms["friction"].append(_Term(i, i, 1.0, m.extra))
    n = len(spec.nodes)
    for key, elements in (("K", spec.springs), ("C", spec.dampers)):
        for e in elements:
            a, b = (index.get(n, -1) if n != GROUND else -1 for n in e.nodes)
            if e.value.strip() not in ("0", "0.0"):
                # a base (index ≥ n) has no row: it moves with its channel; its column holds
                # −k (−c), the left-hand side's share of k (x_b − q_i)
                for r, c, s in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
                    if 0 <= r < n and c >= 0:
                        terms[key].append(_Term(r, c, s, e.value))
            if e.extra:
                terms["cubic"].append(_Term(a, b, 1.0, e.extra))
    return {k: tuple(v) for k, v in terms.items()}


def _affine_terms(terms: dict, names: tuple) -> dict | None:
    """expression text -> (c₀, ∇) when every expression is affine in θ (checked with sympy on
    the parsed expression: each ∂e/∂θ_p is a constant); None otherwise."""
    import sympy as sp

    from ..expressions import parse_expression

    symbols = {p: sp.Symbol(p) for p in names}
    out = {}
    for group in terms.values():
        for t in group:
            if t.text in out:
                continue
            expr = parse_expression(t.text, symbols)
            grad = [sp.diff(expr, symbols[p]) for p in names]
            if any(g.free_symbols for g in grad):
                return None
            c0 = expr.subs({s: 0 for s in symbols.values()})
            try:
                out[t.text] = (float(c0), np.array([float(g) for g in grad]))
            except TypeError:
                return None
    return out


def _check_mass(model: StructureModel, spec: StructureSpec) -> None:
    vals = model.parameters
    M = model.matrices(vals)[0]
    for m in spec.masses:
        i = model.nodes.index(m.nodes[0])
        if not M[i, i] > 0:
            raise ModelFileError(
                f"{m.where}: mass {m.nodes[0]!r} = {m.value} is {M[i, i]:g} kg at the nominal "
                "values; a mass must be positive (M would be singular)."
            )
    if not np.allclose(M, M.T, rtol=1e-12, atol=0):
        raise ModelFileError(f"{spec.source} (matrices.M): M must be symmetric; got {M.tolist()}.")
    eig = np.linalg.eigvalsh(M)
    if eig[0] <= 1e-12 * max(abs(eig[-1]), 1e-300):
        raise ModelFileError(
            f"{spec.source} (matrices.M): M is singular or not positive definite at the nominal "
            f"values (eigenvalues {np.round(eig, 12).tolist()} kg); every coordinate needs "
            "inertia (a massless node is a constraint, not a coordinate: eliminate it)."
        )


def _verdict(names, null) -> tuple[list, list, list]:
    """Identifiable and unidentifiable parameters and the null directions in words."""
    if null is None or null.size == 0:
        return list(names), [], []
    weight = np.sum(null**2, axis=0)
    unident = [p for p, w in zip(names, weight, strict=True) if w > 1e-6]
    ident = [p for p in names if p not in unident]
    directions = []
    for v in null:
        v = v / np.max(np.abs(v))
        parts = [f"{p} {c:+.3g}" for p, c in zip(names, v, strict=True) if abs(c) > 1e-3]
        directions.append(
            "changing the logarithms of " + ", ".join(parts) + " (in proportion) leaves every "
            "output unchanged"
        )
    return ident, unident, directions
