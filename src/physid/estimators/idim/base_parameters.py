"""IDIM stage 2a: the base parameters of a model and its base regressor W = Y[..., independent].

Shared by IDIM and input-error over base parameters (`physid.estimators.input_error.linear`):
`base_regressor_info` (names, expressions, kept columns, K), `base_regressor` (the regressor's
kept columns evaluated in blocks of samples) and `unit_of` (the unit of a base parameter: that of
its kept column).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ...errors import InputError

__all__ = ["BaseInfo", "base_regressor_info", "base_regressor", "unit_of", "joint_of"]


@dataclass(frozen=True)
class BaseInfo:
    """The base-parameter set of a model as IDIM uses it (see `base_regressor_info`).

    Attributes
    ----------
    names : tuple of str
        The base parameters' names as ``model.base_parameters()`` (and ``physid model info``)
        give them: the kept regressor column, with an ``R`` when other columns are regrouped
        into it (``"ZZ1R"``), so that a base value is never taken for the standard parameter of
        the same name. Models whose columns are monomials of their parameters (``"m3*l3"``)
        keep the kept column's name (no model takes it as a parameter).
    expressions : tuple of str
        Each base parameter as a combination of the standard ones, e.g. ``"ZZ1 + YY2 + ..."``.
    columns : ndarray of int, shape (p,)
        Indices of `independent` in the model's regressor columns.
    matrix : ndarray, shape (p, n_cols)
        K, with ``β_base = K β``.
    column_names : tuple of str
        The model's regressor column names (β).
    independent : tuple of str
        The regressor column kept for each base parameter (its leading term), e.g. ``"ZZ1"``.
    """

    names: tuple[str, ...]
    expressions: tuple[str, ...]
    columns: np.ndarray
    matrix: np.ndarray
    column_names: tuple[str, ...]
    independent: tuple[str, ...] = ()

    @property
    def n_base(self) -> int:
        """Number of base parameters p."""
        return len(self.names)

    def from_standard(self, beta) -> np.ndarray:
        """β_base = K β for a full vector of regressor parameters β, shape (n_cols,)."""
        return self.matrix @ np.asarray(beta, dtype=float)


def base_regressor_info(model) -> BaseInfo:
    """Base parameters of a model: kept columns, their expressions and the matrix K.

    Parameters
    ----------
    model : ChainModel
        A model with ``regressor``, ``beta_names`` (or ``regressor_names``) and
        ``base_parameters()``.

    Returns
    -------
    BaseInfo

    Raises
    ------
    InputError
        The model has no linear-in-parameters form.
    """
    for attr in ("regressor", "base_parameters"):
        if not hasattr(model, attr):
            raise InputError(
                f"IDIM needs a model that is linear in its base parameters (with {attr!r}); "
                f"{type(model).__name__} has none. Use the input-error method."
            )
    column_names = tuple(getattr(model, "regressor_names", None) or model.beta_names)
    bp = model.base_parameters()
    independent = tuple(bp.independent)
    expressions = tuple(getattr(bp, "expressions", None) or bp.base_names)
    base_names = tuple(getattr(bp, "base_names", None) or independent)
    names = independent if any(re.search(r"\s", n) for n in base_names) else base_names
    index = {n: i for i, n in enumerate(column_names)}
    columns = np.array([index[n] for n in independent], dtype=int)
    return BaseInfo(
        names,
        expressions,
        columns,
        np.asarray(bp.base_matrix, float),
        column_names,
        independent,
    )


def base_regressor(model, columns, q, qd, qdd, *, block: int = 8192, out=None) -> np.ndarray:
    """W = Y(q, q̇, q̈)[:, :, columns], evaluated in blocks of samples.

    Parameters
    ----------
    model : ChainModel
        With ``regressor(q, qd, qdd)`` of shape (n, n_joints, n_cols).
    columns : sequence of int
        The kept (independent) regressor columns (`BaseInfo.columns`).
    q, qd, qdd : ndarray, shape (n, n_joints) [rad, rad/s, rad/s²]
    block : int
        Samples per evaluation of the full regressor.
    out : ndarray, shape (n, n_joints, len(columns)), optional
        Written in place (its rows may be a wider array's: a view of its leading columns).

    Returns
    -------
    ndarray, shape (n, n_joints, len(columns)) [N·m per unit of each base parameter]
        Peak memory: this array plus one block of the full regressor (block, n_joints, n_cols);
        a model with `regressor_columns` (the compiled rigid chain) needs no such block.
    """
    columns = np.asarray(columns, dtype=int)
    n = q.shape[0]
    if out is None:
        out = np.empty((n, q.shape[1], columns.size))
    direct = getattr(model, "regressor_columns", None)
    for s in range(0, n, block):
        sl = slice(s, s + block)
        if direct is not None:  # the columns gathered in C, sample by sample
            direct(q[sl], qd[sl], qdd[sl], columns, out[sl])
        else:
            full = np.asarray(model.regressor(q[sl], qd[sl], qdd[sl]), dtype=float)
            out[sl] = full[:, :, columns]
    return out


def write_in_place(dest, n_joints: int, p: int, fill) -> None:
    """``fill(out)`` with ``out`` the rows ``dest`` (m, n_joints·p) seen as (m, n_joints, p):
    written in place when that view shares ``dest``'s memory (the usual case, also for a wider
    array's leading columns), else through a copy assigned back."""
    out = dest.reshape(dest.shape[0], n_joints, p)
    fill(out)
    if not np.shares_memory(out, dest):
        dest[...] = out.reshape(dest.shape[0], -1)


# ---------------------------------------------------------------------- units
#: Unit of each standard-parameter prefix (revolute joint; `_PRISMATIC_UNITS` for prismatic).
_STANDARD_UNITS = {
    "m": "kg",
    "mcx": "kg*m",
    "mcy": "kg*m",
    "mcz": "kg*m",
    "XX": "kg*m**2",
    "XY": "kg*m**2",
    "XZ": "kg*m**2",
    "YY": "kg*m**2",
    "YZ": "kg*m**2",
    "ZZ": "kg*m**2",
    "Ia": "kg*m**2",
    "Fv": "N*m*s/rad",
    "Fvp": "N*m*s/rad",
    "Fvn": "N*m*s/rad",
    "Fc": "N*m",
    "Fcp": "N*m",
    "Fcn": "N*m",
    "OF": "N*m",
}
_PRISMATIC_UNITS = {"Ia": "kg", "Fv": "N*s/m", "Fvp": "N*s/m", "Fvn": "N*s/m"}
_PRISMATIC_UNITS.update({k: "N" for k in ("Fc", "Fcp", "Fcn", "OF")})


def unit_of(name: str, model) -> str:
    """Unit of a regressor column: standard-parameter prefix, or a monomial of model units.

    A base parameter has the unit of its kept column (IDIM's and input-error's results).
    """
    match = re.fullmatch(r"([A-Za-z]+?)(\d+)", name)
    if match and match[1] in _STANDARD_UNITS:
        prefix, j = match[1], int(match[2])
        types = getattr(model, "joint_types", None)
        if types is not None and j - 1 < len(types) and types[j - 1] == "prismatic":
            return _PRISMATIC_UNITS.get(prefix, _STANDARD_UNITS[prefix])
        return _STANDARD_UNITS[prefix]
    units = getattr(model, "units", {}) or {}
    parts = []
    for factor in name.split("*"):
        if not factor:
            continue
        if factor in units and units[factor]:
            parts.append(units[factor])
        elif re.fullmatch(r"\d+", factor) and parts:
            parts[-1] = f"{parts[-1]}**{factor}"
    text = "*".join(parts).replace("**2*", "**2*")
    return text


def joint_of(name: str) -> int | None:
    """The joint number a parameter name ends with (``"ZZ2R"`` -> 2), or None."""
    match = re.search(r"(\d+)(?:\*\*\d+)?R?$", name)
    return int(match[1]) if match else None
