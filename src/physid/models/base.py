"""Base parameters of models linear in their parameters (τ = Y β): the numerical method.

QR with column pivoting of the column-scaled regressor stacked over random states (Gautier, 1990)
gives the rank (the number of base parameters), the independent columns, and for each dependent
column its exact combination of the independent ones, so that β_base = K β and
τ = Y[..., independent] β_base. Each base parameter is written as an expression of the standard
parameters ("ZZ1 + YY2 + 0.09*m2") and in words.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

__all__ = [
    "RANK_RTOL",
    "RigidBaseParameters",
    "base_parameters_of_regressor",
    "format_combination",
    "qr_base",
    "regrouping",
]

#: Rank threshold of the base parameters: a regressor column that the others reproduce to within
#: this fraction of its norm (|R_kk| / |R_00| of the column-scaled QR with pivoting) is regrouped
#: into them (`regrouping`). Such a column costs any fit a condition number of at least 1e4 for a
#: difference of that size, while geometry rounded in a file would otherwise make it a base
#: parameter of its own: the xArm7 URDF of example-robot-data writes 1.5708 for π/2, and its Ia2
#: column is then the ZZ2 column to 4.5e-6, a condition number of 2e7 for any recording. The
#: exact URDF arms of the benchmark zoo (arm6, UR5, Panda, the xArm7 with exact right angles)
#: keep no column below 0.4 and regroup none above 1e-14; the symbolic manipulator model keeps
#: its smallest at 0.028.
RANK_RTOL = 1e-4


def format_combination(coeffs, names, *, digits: int = 6, tol: float = 1e-9) -> str:
    """``"ZZ1 + YY2 + 0.0625*m2 - XX3"`` from coefficients and names (terms below tol dropped).

    Parameters
    ----------
    coeffs : array_like (n,)
    names : sequence of str (n,)
    digits : int
        Significant digits of the coefficients.
    tol : float

    Returns
    -------
    str
    """
    terms = []
    for c, name in zip(coeffs, names, strict=False):
        c = float(c)
        if abs(c) < tol:
            continue
        if abs(c - 1) < tol:
            terms.append(f"+ {name}")
        elif abs(c + 1) < tol:
            terms.append(f"- {name}")
        else:
            terms.append(f"{'-' if c < 0 else '+'} {abs(c):.{digits}g}*{name}")
    text = " ".join(terms)
    if not text:
        return "0"
    return text[2:] if text.startswith("+ ") else "-" + text[2:]


def qr_base(Y, rtol: float = RANK_RTOL, order=None):
    """Rank, independent columns (in column order) and K (rank × n_cols) of a stacked regressor.

    The rank comes from QR with column pivoting of the column-scaled matrix; the base set is then
    chosen greedily in ``order`` (a column is kept when it is not a combination of the columns
    kept before it), so that the names follow a convention (e.g. Khalil's: YY_j, mcz_j and m_j
    are the ones regrouped). When the greedy choice does not reach the rank (round-off), the
    pivoted choice is used.

    Parameters
    ----------
    Y : ndarray (n_rows, n_cols)
    rtol : float
        Rank threshold on |R_kk| / |R_00| after scaling every column to unit norm.
    order : sequence of int, optional
        Priority of the columns (default: their order).

    Returns
    -------
    independent : ndarray of int (rank,)
        Sorted column indices of the base set.
    K : ndarray (rank, n_cols)
        β_base = K β; K[:, independent] is the identity.
    zero : ndarray of int
        Columns that are identically zero (parameters with no effect).
    """
    import scipy.linalg

    n_cols = Y.shape[1]
    norms = np.linalg.norm(Y, axis=0)
    scale = norms.max() if norms.size else 1.0
    zero = np.flatnonzero(norms <= 1e-10 * max(scale, 1e-300))
    Ys = Y / np.where(norms > 0, norms, 1.0)
    Ys[:, zero] = 0.0
    _, R, perm = scipy.linalg.qr(Ys, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    rank = int(np.sum(diag > rtol * diag[0])) if diag.size and diag[0] > 0 else 0
    ind = np.sort(perm[:rank])
    order = np.arange(n_cols) if order is None else np.asarray(order, dtype=int)
    nz = [c for c in order if c not in set(zero.tolist())]
    if nz and rank:
        R2 = scipy.linalg.qr(Ys[:, nz], mode="r")[0]
        d2 = np.abs(np.diag(R2))
        greedy = np.sort(np.asarray(nz)[: d2.size][d2 > max(1e-7, rtol)])
        if greedy.size == rank:
            ind = greedy
    dep = np.setdiff1d(np.arange(n_cols), ind)
    K = np.zeros((rank, n_cols))
    K[np.arange(rank), ind] = 1.0
    dep = np.setdiff1d(dep, zero)  # a column with no effect regroups into nothing: K is 0 there
    if dep.size and rank:
        C = regrouping(Y, ind, dep, rtol)
        C[np.abs(C) < 1e-10 * max(1.0, float(np.abs(C).max()))] = 0.0
        K[:, dep] = C
    return ind, K, zero


def regrouping(Y, ind, dep, rtol: float = RANK_RTOL) -> np.ndarray:
    """C with ``Y[:, dep] ≈ Y[:, ind] C``: how each dependent column regroups into the kept ones.

    An exactly dependent column (least-squares residual at most 1e-9 of its norm) gets its
    least-squares coefficients. A column the kept ones reproduce only to within ``rtol``
    (rounded geometry) would get least-squares coefficients spread over every kept column at the
    level of its residual (1e-9 to 1e-6 on a URDF that writes 1.5708 for π/2), which would
    regroup it, in name and expression, into all of them; there the smallest contributions
    ``|C_ij|·‖Y_i‖`` are dropped while their sum stays below ``rtol·‖Y_j‖``, and the others
    fitted again (so the residual stays within the threshold).

    Parameters
    ----------
    Y : ndarray, shape (n_rows, n_cols)
        The stacked regressor.
    ind, dep : ndarray of int
        The kept and the dependent columns.
    rtol : float
        The rank threshold the base set was chosen with.

    Returns
    -------
    ndarray, shape (len(ind), len(dep))
    """
    Yi, Yd = Y[:, ind], Y[:, dep]
    C, *_ = np.linalg.lstsq(Yi, Yd, rcond=None)
    n_ind, n_dep = np.linalg.norm(Yi, axis=0), np.linalg.norm(Yd, axis=0)
    residual = np.linalg.norm(Yd - Yi @ C, axis=0)
    for k in np.flatnonzero(residual > 1e-9 * n_dep):  # per approximately dependent column
        contribution = np.abs(C[:, k]) * n_ind
        order = np.argsort(contribution)
        small = order[np.cumsum(contribution[order]) < rtol * n_dep[k]]
        keep = np.ones(len(ind), dtype=bool)
        keep[small] = False
        C[:, k] = 0.0
        if keep.any():
            C[keep, k] = np.linalg.lstsq(Yi[:, keep], Yd[:, k], rcond=None)[0]
    return C


#: Khalil's preference within a link: the parameters regrouped into others come last.
_LINK_PRIORITY = ("XX", "XY", "XZ", "YZ", "ZZ", "mcx", "mcy", "YY", "mcz", "m")


def _priority(names, per_joint, n_joints):
    order = []
    for j in range(n_joints):
        block = list(range(j * per_joint, (j + 1) * per_joint))
        std = block[:10]
        by_name = {names[c].rstrip("0123456789"): c for c in std}
        order += [by_name[k] for k in _LINK_PRIORITY if k in by_name]
    for j in range(n_joints):
        order += list(range(j * per_joint + 10, (j + 1) * per_joint))
    return order


@dataclass(frozen=True)
class RigidBaseParameters:
    """Base parameters of a model linear in its parameters.

    Attributes
    ----------
    beta_names : tuple of str
        All regressor columns (standard and drive parameters).
    n_beta, n_base : int
    base_names : tuple of str
        One short name per base parameter: the leading standard parameter, with suffix ``R``
        when others are regrouped into it (``ZZ2R``), as in Khalil's notation.
    expressions : tuple of str
        Each base parameter as a combination of standard parameters, ``"ZZ2 + 0.1806*m3 + …"``.
    words : tuple of str
        Each base parameter in words.
    base_matrix : ndarray (n_base, n_beta)
        K with β_base = K β.
    independent : tuple of str
        The columns kept: τ = Y[..., independent] @ β_base.
    independent_index : tuple of int
    no_effect : tuple of str
        Parameters whose column is identically zero (they never affect τ).
    parameter_names : tuple of str
    theta_rank : int
        Equals n_base (θ = β).
    unidentifiable : tuple of str
        Plain-language statements of what cannot be identified separately.
    combinations : tuple of Combination
        The same as `physid.models.identifiability.Combination` objects.
    null_directions : ndarray (n_beta, n_beta − n_base)
        Directions of β that leave τ unchanged.
    """

    beta_names: tuple
    n_beta: int
    n_base: int
    base_names: tuple
    expressions: tuple
    words: tuple
    base_matrix: np.ndarray
    independent: tuple
    independent_index: tuple
    no_effect: tuple
    parameter_names: tuple
    theta_rank: int
    unidentifiable: tuple
    combinations: tuple
    null_directions: np.ndarray

    def values(self, beta) -> np.ndarray:
        """β_base = K β for a full parameter vector.

        Parameters
        ----------
        beta : array_like (n_beta,)

        Returns
        -------
        ndarray (n_base,)
        """
        return self.base_matrix @ np.asarray(beta, dtype=float)

    def summary(self) -> str:
        """Multi-line text: the count and each base parameter with its expression."""
        lines = [f"{self.n_base} base parameters of {self.n_beta} standard/drive parameters."]
        width = max((len(b) for b in self.base_names), default=0)
        lines += [
            f"  {b:<{width}} = {e}" for b, e in zip(self.base_names, self.expressions, strict=True)
        ]
        if self.no_effect:
            lines.append(f"  no effect on τ: {', '.join(self.no_effect)}")
        return "\n".join(lines)

    @property
    def description(self) -> str:
        """Same as `summary`."""
        return self.summary()

    def to_dict(self) -> dict:
        """JSON-ready dictionary (arrays as nested lists, Combinations as dicts)."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                v = v.tolist()
            elif f.name == "combinations":
                v = [dataclasses.asdict(c) for c in v]
            elif isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        return out


def _random_states(model, ns, rng, limits=None):
    n = model.n_joints
    q = rng.uniform(-np.pi, np.pi, (ns, n))
    for j, kind in enumerate(getattr(model, "joint_types", ("revolute",) * n)):
        if kind == "prismatic":
            lo, hi = -0.5, 0.5
            if limits is not None:
                pl = limits["position"][j]
                if np.all(np.isfinite(pl)) and pl[1] > pl[0]:
                    lo, hi = pl
            q[:, j] = rng.uniform(lo, hi, ns)
    return q, rng.normal(size=(ns, n)), rng.normal(size=(ns, n))


def _words(k_row, names, lead):
    others = [names[i] for i in np.flatnonzero(np.abs(k_row) > 1e-9) if names[i] != lead]
    if not others:
        return f"{lead} alone (identifiable by itself)"
    joined = ", ".join(others[:-1]) + (" and " if len(others) > 1 else "") + others[-1]
    return (
        f"{lead} regrouped with {joined}: their effects on the torques cannot be told apart, "
        "only this combination can be identified"
    )


def base_parameters_of_regressor(model, *, n_states=None, seed=0, rtol=RANK_RTOL, limits=None):
    """Base parameters of a model whose parameters are its regressor's columns.

    Parameters
    ----------
    model : RigidBodyModel
    n_states : int, optional
        Random states stacked (default ``max(60, 2 n_cols / n_joints + 20)``).
    seed : int
    rtol : float
    limits : dict, optional
        Position limits used for prismatic joints' random states.

    Returns
    -------
    RigidBaseParameters
    """
    from .identifiability import Combination

    names = tuple(model.regressor_names)
    nb = len(names)
    nj = model.n_joints
    ns = n_states or max(60, 2 * nb // max(nj, 1) + 20)
    rng = np.random.default_rng(seed)
    q, qd, qdd = _random_states(model, ns, rng, limits)
    Y = model.regressor(q, qd, qdd).reshape(ns * nj, nb)
    per = nb // nj if nj else nb
    order = _priority(names, per, nj) if per >= 10 and per * nj == nb else None
    ind, K, zero = qr_base(Y, rtol, order)
    # lead name: the independent column; 'R' when other columns are regrouped into it
    base_names, expressions, words = [], [], []
    for r, i in enumerate(ind):
        regrouped = np.count_nonzero(np.abs(K[r]) > 1e-9) > 1
        base_names.append(f"{names[i]}R" if regrouped else names[i])
        expressions.append(format_combination(K[r], names))
        words.append(_words(K[r], names, names[i]))
    # null space of K (directions of β invisible in τ)
    _, s, Vt = np.linalg.svd(K) if K.size else (None, np.zeros(0), np.eye(nb))
    null = Vt[len(ind) :].T if K.size else np.eye(nb)
    zero_names = tuple(names[i] for i in zero)
    combos = []
    statements = []
    for name in zero_names:
        text = f"{name} has no effect on the torques (its regressor column is zero)"
        statements.append(text)
        combos.append(Combination((name,), f"{name} (no effect)", {name: 1.0}, text))
    for r in range(len(ind)):
        support = [names[c] for c in np.flatnonzero(np.abs(K[r]) > 1e-9)]
        if len(support) > 1:
            text = f"{', '.join(support[:-1])} and {support[-1]} enter only as {expressions[r]}"
            statements.append(text)
            combos.append(
                Combination(
                    tuple(support),
                    expressions[r],
                    {names[c]: float(K[r, c]) for c in np.flatnonzero(np.abs(K[r]) > 1e-9)},
                    text,
                )
            )
    return RigidBaseParameters(
        beta_names=names,
        n_beta=nb,
        n_base=len(ind),
        base_names=tuple(base_names),
        expressions=tuple(expressions),
        words=tuple(words),
        base_matrix=K,
        independent=tuple(names[i] for i in ind),
        independent_index=tuple(int(i) for i in ind),
        no_effect=zero_names,
        parameter_names=names,
        theta_rank=len(ind),
        unidentifiable=tuple(statements),
        combinations=tuple(combos),
        null_directions=null,
    )
