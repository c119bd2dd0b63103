"""Cache of a rigid-body model's base parameters: in memory on the model, and on disk.

`RigidBodyModel.base_parameters` stacks the regressor over random states and runs two QR
factorisations; IDIM calls it on every fit. The result depends only on the chain's geometry
(joint types, placements, axes, the link-to-joint maps, gravity, the drive terms present, the
prismatic position limits that bound the random states) and on the settings ``n_states``,
``seed`` and ``rtol`` — never on the nominal inertial values (τ = Y β and Y does not depend on
β). The disk entry (``base-<key>.json`` in the folder of `physid.models._cache`) is keyed by a
SHA-256 of exactly that content, of this module's and the base-parameter code's source
(`code_fingerprint`) and of the cache format, so a change of any of them misses.

An entry is used only after two checks: its stored content must equal the model's content
(a renamed or copied file from another model fails), and the cached base set must reproduce
the model's regressor at a few fresh random states, ``Y ≈ Y[:, ind] K`` (a tampered or stale
matrix fails). Anything else (unreadable, other format, failed check) is a miss: the base
parameters are derived again and the entry is rewritten. The entries are read and written
through `physid.models._cache`, so its trust rule (a private folder, private entries, a keyed
HMAC) applies to them as well.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

import numpy as np

from . import _cache

__all__ = ["base_cache_key", "base_content", "cached_base_parameters", "verify_base"]

#: Bump when the entry layout changes.
BASE_FORMAT = "physid-base-1"
KIND = "base"


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Hash of the modules whose code decides the base set (any edit misses the cache)."""
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for name in ("_base_cache.py", "base.py", "rigid.py", "transmission.py"):
        try:
            digest.update((here / name).read_bytes())
        except OSError:  # pragma: no cover - zipped install: the format string still guards
            digest.update(name.encode())
    return digest.hexdigest()[:16]


def base_content(model, *, n_states, seed, rtol) -> dict:
    """JSON-ready description of everything the base parameters of ``model`` depend on.

    Parameters
    ----------
    model : RigidBodyModel
    n_states, seed, rtol :
        The settings of `RigidBodyModel.base_parameters`.

    Returns
    -------
    dict
    """
    chain = model.chain
    prismatic = [j for j, k in enumerate(model.joint_types) if k == "prismatic"]
    position = np.asarray(model.limits.get("position", np.full((model.n_joints, 2), np.nan)))
    return {
        "format": BASE_FORMAT,
        "code": code_fingerprint(),
        "chain": chain.content(),
        "link_to_joint": np.asarray(chain.link_to_joint).round(15).tolist(),
        "names": list(model.regressor_names),
        "prismatic_limits": [
            [None if not np.isfinite(v) else float(v) for v in position[j]] for j in prismatic
        ],
        "n_states": None if n_states is None else int(n_states),
        "seed": int(seed),
        "rtol": float(rtol),
    }


def base_cache_key(content: dict) -> str:
    """The disk key of a `base_content` (SHA-256 via `physid.models._cache.content_key`)."""
    return _cache.content_key(content)


def _to_data(bp, content: dict) -> dict:
    data = bp.to_dict()
    data["content"] = content
    return data


def _from_data(data: dict):
    from .base import RigidBaseParameters
    from .identifiability import Combination

    combos = tuple(
        Combination(tuple(c["parameters"]), c["expression"], dict(c["direction"]), c["text"])
        for c in data["combinations"]
    )
    nb = int(data["n_beta"])
    null = np.asarray(data["null_directions"], dtype=float).reshape(nb, -1)
    return RigidBaseParameters(
        beta_names=tuple(data["beta_names"]),
        n_beta=nb,
        n_base=int(data["n_base"]),
        base_names=tuple(data["base_names"]),
        expressions=tuple(data["expressions"]),
        words=tuple(data["words"]),
        base_matrix=np.asarray(data["base_matrix"], dtype=float).reshape(int(data["n_base"]), nb),
        independent=tuple(data["independent"]),
        independent_index=tuple(int(i) for i in data["independent_index"]),
        no_effect=tuple(data["no_effect"]),
        parameter_names=tuple(data["parameter_names"]),
        theta_rank=int(data["theta_rank"]),
        unidentifiable=tuple(data["unidentifiable"]),
        combinations=combos,
        null_directions=null,
    )


def verify_base(
    model,
    bp,
    *,
    n_states: int = 8,
    seed: int = 20260,
    rtol: float = 1e-7,
    rank_rtol: float = 0.0,
) -> bool:
    """Whether a base set reproduces the model's regressor at fresh random states.

    Checks the names, the shapes, ``K[:, ind] = I`` and, column by column on ``n_states`` random
    states (a few microseconds with the C kernel), ``‖Y_j − Y[:, ind] K_j‖ ≤ rtol ‖Y‖ +
    s ‖Y_j‖`` with ``s = min(10 rank_rtol, 1e-3)``: a column regrouped to within the rank
    threshold (`physid.models.base.regrouping`) leaves up to about ``rank_rtol`` of its own norm
    at the derivation's states, a little more at others; the cap keeps a large threshold from
    accepting a tampered matrix.

    Parameters
    ----------
    model : RigidBodyModel
    bp : RigidBaseParameters
    n_states, seed : int
        Random states of the check (other than those of the derivation).
    rtol : float
    rank_rtol : float
        The rank threshold the base set was derived with.

    Returns
    -------
    bool
    """
    from .base import _random_states

    names = tuple(model.regressor_names)
    try:
        K = np.asarray(bp.base_matrix, dtype=float)
        ind = np.asarray(bp.independent_index, dtype=int)
        if (
            tuple(bp.beta_names) != names
            or K.shape != (bp.n_base, len(names))
            or ind.shape != (bp.n_base,)
            or tuple(names[i] for i in ind) != tuple(bp.independent)
            or not np.allclose(K[:, ind], np.eye(bp.n_base), atol=1e-12)
        ):
            return False
        q, qd, qdd = _random_states(model, n_states, np.random.default_rng(seed), model.limits)
        Y = np.asarray(model.regressor(q, qd, qdd), dtype=float).reshape(-1, len(names))
        err = np.linalg.norm(Y - Y[:, ind] @ K, axis=0)
        norms = np.linalg.norm(Y, axis=0)
        scale = max(float(norms.max()), 1e-300)
        slack = min(10.0 * rank_rtol, 1e-3)
        return bool(np.all(err <= rtol * scale + slack * norms + 1e-12))
    except (KeyError, ValueError, TypeError, IndexError):
        return False


def cached_base_parameters(model, derive, *, n_states, seed, rtol, enabled: bool = True):
    """The base parameters of ``model`` from the disk cache if valid, else ``derive()``.

    Parameters
    ----------
    model : RigidBodyModel
    derive : callable
        ``derive() -> RigidBaseParameters`` (the computation).
    n_states, seed, rtol :
        Settings (part of the key).
    enabled : bool
        Read and write the disk cache.

    Returns
    -------
    (RigidBaseParameters, bool)
        The base parameters and whether they came from the disk.
    """
    if not enabled:
        return derive(), False
    content = base_content(model, n_states=n_states, seed=seed, rtol=rtol)
    key = base_cache_key(content)
    data = _cache.load_entry(KIND, key)
    if data is not None and data.get("content") == content:
        try:
            bp = _from_data(data)
        except (KeyError, ValueError, TypeError):
            bp = None
        if bp is not None and verify_base(model, bp, rank_rtol=rtol):
            return bp, True
    bp = derive()
    _cache.save_entry(KIND, key, _to_data(bp, content))
    return bp, False
