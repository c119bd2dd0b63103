"""The on-disk derivation cache (PHYSID_CACHE_DIR): chain models' generated sources, compiled
libraries and base-parameter sets are verified before use; a tampered or foreign entry is
derived again, never executed or trusted."""

from __future__ import annotations

import dataclasses
import json

import numpy as np

import physid
from _helpers import DATA, PLANAR2
from physid.models import _base_cache, _cache
from physid.models.base import RANK_RTOL

# ---------------------------------------------------------- generated sources and shared libraries
PENDULUM = """
name = "pendulum_cache_check"
gravity = [0.0, -9.81, 0.0]
[parameters]
m = { value = 1.3, unit = "kg" }
l = { value = 0.7, unit = "m" }
[[joints]]
dh = { a = "l", alpha = 0 }
mass = "m"
"""


def test_tampered_cached_source_is_regenerated_and_never_runs(tmp_path, monkeypatch):
    from physid.models.chain import build_chain_model
    from physid.models.spec import parse_model_text

    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path / "cache"))
    first = build_chain_model(parse_model_text(PENDULUM, source="<test>"))
    assert not first.loaded_from_cache
    (entry_path,) = (tmp_path / "cache").glob("chain-*.json")
    entry = json.loads(entry_path.read_text())
    marker = tmp_path / "tampered-code-ran"
    evil = f"__import__('pathlib').Path({str(marker)!r}).write_text('ran')\n"
    entry["data"]["sources"]["tau"] = evil + entry["data"]["sources"]["tau"]
    entry_path.write_text(json.dumps(entry))  # format, key and the old sha256 kept

    second = build_chain_model(parse_model_text(PENDULUM, source="<test>"))
    assert not marker.exists()  # the altered source was refused before exec
    assert not second.loaded_from_cache  # ... and derived again
    q = np.array([[0.3]])
    # τ = m l² q̈ + m g l cos q (point mass at the link's end, gravity along −y)
    expected = 1.3 * 0.7**2 * 2.0 + 1.3 * 9.81 * 0.7 * np.cos(0.3)
    np.testing.assert_allclose(second.inverse_dynamics(q, 0 * q, q * 0 + 2.0), [[expected]],
                               rtol=1e-12)  # fmt: skip
    assert "__import__" not in json.loads(entry_path.read_text())["data"]["sources"]["tau"]
    third = build_chain_model(parse_model_text(PENDULUM, source="<test>"))
    assert third.loaded_from_cache  # the rewritten entry verifies


def test_cached_shared_library_is_verified_before_loading(tmp_path, monkeypatch):
    import subprocess
    import sys

    from physid.models.codegen import build_shared_library, compiler

    cache = tmp_path / "cache"
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(cache))
    good = "int answer(void) { return 7; }\n"
    if compiler() is None:  # nothing is built or loaded without a compiler
        assert build_shared_library(good, "goodlib") is None
        return
    # an earlier process built and cached the good library
    script = (
        "from physid.models.codegen import build_shared_library as b; "
        f"print(b({good!r}, 'goodlib').answer())"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.stdout.strip() == "7", done.stderr
    (lib_path,) = cache.glob("goodlib-*.so")
    marker = tmp_path / "tampered-library-ran"
    evil = (
        "#include <stdio.h>\n"
        "__attribute__((constructor)) static void run(void) {\n"
        f'  FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n'
        "int answer(void) { return 666; }\n"
    )
    assert build_shared_library(evil, "evillib").answer() == 666
    assert marker.exists()  # the evil library runs its constructor when it is loaded ...
    marker.unlink()
    (evil_path,) = cache.glob("evillib-*.so")
    lib_path.write_bytes(evil_path.read_bytes())  # ... and now sits in place of the good one
    again = build_shared_library(good, "goodlib")
    assert not marker.exists()  # the tampered file was never loaded
    assert again.answer() == 7  # it was rebuilt from the source


# ------------------------------------------------------------------ base parameters
def _fresh(path):
    return physid.load_model(path)


def test_base_parameter_cache_hit_is_identical(tmp_path, monkeypatch):
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path))
    a = _fresh(PLANAR2)
    bp = a.base_parameters()
    assert not a.base_from_cache
    assert a.base_parameters() is bp  # in memory on the model
    assert not bp.base_matrix.flags.writeable
    files = sorted(tmp_path.glob("base-*.json"))
    assert len(files) == 1
    b = _fresh(PLANAR2)
    hit = b.base_parameters()
    assert b.base_from_cache
    np.testing.assert_array_equal(hit.base_matrix, bp.base_matrix)
    np.testing.assert_array_equal(hit.null_directions, bp.null_directions)
    for name in ("beta_names", "base_names", "expressions", "independent", "words", "combinations"):
        assert getattr(hit, name) == getattr(bp, name), name
    assert hit.n_base == bp.n_base == 6
    # other settings are another entry
    b.base_parameters(seed=1)
    assert len(list(tmp_path.glob("base-*.json"))) == 2


def test_tampered_or_foreign_cache_entries_are_not_used(tmp_path, monkeypatch):
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path))
    good = _fresh(PLANAR2).base_parameters()
    (path,) = tmp_path.glob("base-*.json")
    entry = json.loads(path.read_text())
    # a tampered matrix (key and content intact): the regressor check rejects it
    K = np.array(entry["data"]["base_matrix"])
    dep = np.flatnonzero(np.abs(K).sum(axis=0) > 0)
    K[0, dep[-1]] += 0.25
    entry["data"]["base_matrix"] = K.tolist()
    path.write_text(json.dumps(entry))
    m = _fresh(PLANAR2)
    again = m.base_parameters()
    assert not m.base_from_cache
    np.testing.assert_array_equal(again.base_matrix, good.base_matrix)
    # another model's entry under this model's key: its stored content differs, not used
    arm3 = _fresh(DATA / "arm3_prismatic.urdf")
    foreign = arm3.base_parameters()
    key = _base_cache.base_cache_key(
        _base_cache.base_content(m, n_states=None, seed=0, rtol=RANK_RTOL)
    )
    content3 = _base_cache.base_content(arm3, n_states=None, seed=0, rtol=RANK_RTOL)
    assert _cache.save_entry("base", key, _base_cache._to_data(foreign, content3))
    m2 = _fresh(PLANAR2)
    assert m2.base_parameters().n_base == good.n_base
    assert not m2.base_from_cache
    # even with the content forged to match, the foreign matrix fails the regressor check
    content = _base_cache.base_content(m2, n_states=None, seed=0, rtol=RANK_RTOL)
    assert _cache.save_entry("base", key, _base_cache._to_data(foreign, content))
    m3 = _fresh(PLANAR2)
    np.testing.assert_array_equal(m3.base_parameters().base_matrix, good.base_matrix)
    assert not m3.base_from_cache
    assert not _base_cache.verify_base(m3, foreign)
    assert _base_cache.verify_base(m3, good)


def test_a_small_tamper_of_a_regrouping_coefficient_is_rejected(tmp_path, monkeypatch):
    # the check allows a regrouped column up to 1e-3 of its own norm (the rank threshold's
    # slack), not a coefficient moved by 1e-2 of the column it regroups
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path))
    m = _fresh(PLANAR2)
    good = m.base_parameters()
    from physid.models.base import _random_states

    K = np.array(good.base_matrix, dtype=float)
    ind = np.asarray(good.independent_index)
    q, qd, qdd = _random_states(m, 8, np.random.default_rng(3), m.limits)
    Y = np.asarray(m.regressor(q, qd, qdd), dtype=float).reshape(-1, K.shape[1])
    norms = np.linalg.norm(Y, axis=0)
    row, col = next((r, c) for r, c in zip(*np.nonzero(K), strict=True) if c not in set(ind))
    bad = K.copy()
    bad[row, col] += 1e-2 * norms[col] / norms[ind[row]]
    tampered = dataclasses.replace(good, base_matrix=bad)
    assert _base_cache.verify_base(m, good, rank_rtol=RANK_RTOL)
    assert not _base_cache.verify_base(m, tampered, rank_rtol=RANK_RTOL)
