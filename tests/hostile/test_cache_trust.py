"""The on-disk cache runs only code the user wrote: private folder, private entries, keyed MAC.

Generated Python source (``chain-*.json``) and compiled libraries (``*.so``) from the cache are
executed, so each test plants code with a side effect (a marker file) and shows that it does not
run when the folder or key file could be changed by someone else, or when an entry was edited
and given a recomputed plain SHA-256.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys

import pytest

from physid._paths import CacheWarning, cache_dir
from physid.errors import InputError
from physid.models import _cache, codegen
from physid.models.chain import build_chain_model
from physid.models.spec import parse_model_text

from ._cases import run_cli

PENDULUM = """
name = "pendulum_cache_trust"
gravity = [0.0, -9.81, 0.0]
[parameters]
m = { value = 1.1, unit = "kg" }
l = { value = 0.45, unit = "m" }
[[joints]]
dh = { a = "l", alpha = 0 }
mass = "m"
"""


def _build():
    return build_chain_model(parse_model_text(PENDULUM, source="<test>"))


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh private cache folder (mode 0700), nothing derived in this process's memory."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(folder))
    monkeypatch.setattr(_cache, "_MEMORY", {})
    monkeypatch.setattr(codegen, "_LIBRARIES", {})
    return folder


def _plant(folder, marker, *, sign: bool) -> dict:
    """Put marker-writing code into the cached entry; give it a plain SHA-256 (and with
    ``sign`` a valid HMAC under the folder's own key). Returns the planted entry."""
    (path,) = folder.glob("chain-*.json")
    entry = json.loads(path.read_text())
    evil = f"__import__('pathlib').Path({str(marker)!r}).write_text('ran')\n"
    entry["data"]["sources"]["tau"] = evil + entry["data"]["sources"]["tau"]
    entry["sha256"] = _cache.data_digest(entry["data"])  # recomputed, as an attacker can
    if sign:
        secret = (folder / "secret.key").read_bytes()
        entry["hmac"] = _cache.entry_mac(secret, "chain", entry["key"], entry["data"])
    path.write_text(json.dumps(entry))
    os.chmod(path, 0o600)
    return entry


def test_cache_folder_and_entries_are_private(cache):
    assert not _build().loaded_from_cache
    assert os.stat(cache).st_mode & 0o777 == 0o700
    assert os.stat(cache / "secret.key").st_mode & 0o777 == 0o600
    (entry,) = cache.glob("chain-*.json")
    assert os.stat(entry).st_mode & 0o777 == 0o600
    assert "hmac" in json.loads(entry.read_text())
    assert _build().loaded_from_cache


def test_group_writable_cache_folder_is_not_used(cache, tmp_path):
    _build()
    marker = tmp_path / "planted-code-ran"
    planted = _plant(cache, marker, sign=True)
    # control: in the private folder the planted entry verifies and its code runs ...
    assert _build().loaded_from_cache
    assert marker.exists()
    marker.unlink()
    os.chmod(cache, 0o770)  # ... once the group may write the folder, nothing in it is used
    with pytest.warns(
        CacheWarning,
        match=r"the cache folder '.*cache' can be written by other users \(mode 0770\), so physid "
        r"does not use the cache .* Fix: chmod 700 '.*cache' .* or set PHYSID_CACHE_DIR",
    ):
        model = _build()
    assert not marker.exists()
    assert not model.loaded_from_cache
    (path,) = cache.glob("chain-*.json")
    assert json.loads(path.read_text()) == planted  # not read, not rewritten


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="needs chown")
def test_cache_folder_of_another_user_is_not_used(cache, tmp_path):
    _build()
    marker = tmp_path / "planted-code-ran"
    _plant(cache, marker, sign=True)
    os.chown(cache, 54321, -1)
    with pytest.warns(CacheWarning, match=r"is owned by user id 54321, not by you \(user id 0\)"):
        model = _build()
    assert not marker.exists()
    assert not model.loaded_from_cache


def test_key_file_readable_by_others_makes_the_cache_untrusted(cache, tmp_path):
    _build()
    marker = tmp_path / "planted-code-ran"
    _plant(cache, marker, sign=True)
    os.chmod(cache / "secret.key", 0o644)
    with pytest.warns(
        CacheWarning,
        match=r"the cache key file '.*secret.key' can be read or written by other users "
        r"\(mode 0644\).* Fix: chmod 600",
    ):
        model = _build()
    assert not marker.exists()
    assert not model.loaded_from_cache


def test_entry_writable_by_others_is_a_miss(cache, tmp_path):
    _build()
    marker = tmp_path / "planted-code-ran"
    _plant(cache, marker, sign=True)
    (path,) = cache.glob("chain-*.json")
    os.chmod(path, 0o666)
    assert not _build().loaded_from_cache
    assert not marker.exists()
    assert os.stat(path).st_mode & 0o777 == 0o600  # rewritten, private again


@pytest.mark.parametrize("legacy", [False, True], ids=["stale-hmac", "no-hmac"])
def test_edited_entry_with_recomputed_sha256_is_a_miss(cache, tmp_path, legacy):
    _build()
    marker = tmp_path / "planted-code-ran"
    entry = _plant(cache, marker, sign=False)  # the HMAC of the original data is kept
    (path,) = cache.glob("chain-*.json")
    if legacy:  # as an older physid wrote it: a plain SHA-256 and no HMAC
        del entry["hmac"]
        path.write_text(json.dumps(entry))
    model = _build()
    assert not marker.exists()
    assert not model.loaded_from_cache
    rewritten = json.loads(path.read_text())
    assert "__import__" not in rewritten["data"]["sources"]["tau"]
    assert _build().loaded_from_cache


def test_relative_cache_dir_is_refused(monkeypatch):
    monkeypatch.setenv("PHYSID_CACHE_DIR", "relative/cache")
    with pytest.raises(
        InputError,
        match=r"the environment variable PHYSID_CACHE_DIR is a relative path "
        r"\('relative/cache'\); the cache folder must be an absolute path",
    ):
        cache_dir()
    with pytest.raises(InputError, match="PHYSID_CACHE_DIR is a relative path"):
        _build()
    res = run_cli(["model", "info", "manipulator"])
    assert res.code == 2
    assert "physid: error: the environment variable PHYSID_CACHE_DIR is a relative path" in res.err


# ------------------------------------------------------------------------ compiled libraries
GOOD = "int answer(void) { return 7; }\n"


def _evil_library(tmp_path, marker) -> bytes:
    """A library that writes ``marker`` when it is loaded (compiled, never loaded here)."""
    src = tmp_path / "evil.c"
    src.write_text(
        "#include <stdio.h>\n"
        "__attribute__((constructor)) static void run(void) {\n"
        f'  FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n'
        "int answer(void) { return 666; }\n"
    )
    out = tmp_path / "evil.so"
    cc = codegen.compiler()
    subprocess.run([cc, "-shared", "-fPIC", "-o", str(out), str(src)], check=True)
    return out.read_bytes()


def _built_elsewhere(tag):
    """Build and cache ``GOOD`` in another process (this one has loaded nothing by that name)."""
    script = (
        "from physid.models.codegen import build_shared_library as b; "
        f"print(b({GOOD!r}, {tag!r}).answer())"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.stdout.strip() == "7", done.stderr


needs_cc = pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")


@needs_cc
def test_library_with_recomputed_sha256_is_not_loaded(cache, tmp_path):
    _built_elsewhere("trustsha")
    (lib,) = cache.glob("trustsha-*.so")
    marker = tmp_path / "planted-library-ran"
    evil = _evil_library(tmp_path, marker)
    lib.write_bytes(evil)
    (cache / f"{lib.name}.sha256").write_text(hashlib.sha256(evil).hexdigest() + "\n")
    again = codegen.build_shared_library(GOOD, "trustsha")
    assert not marker.exists()
    assert again.answer() == 7  # rebuilt from the source


@needs_cc
def test_library_in_group_writable_folder_is_not_loaded(cache, tmp_path, monkeypatch):
    _built_elsewhere("trustdir")
    (lib,) = cache.glob("trustdir-*.so")
    marker = tmp_path / "planted-library-ran"
    evil = _evil_library(tmp_path, marker)
    secret = (cache / "secret.key").read_bytes()
    lib.write_bytes(evil)
    (cache / f"{lib.name}.hmac").write_text(codegen._library_mac(secret, lib.name, evil) + "\n")
    os.chmod(cache, 0o775)
    with pytest.warns(CacheWarning, match=r"cache folder .* can be written by other users"):
        built = codegen.build_shared_library(GOOD, "trustdir")
    assert not marker.exists()
    assert built.answer() == 7  # built in a private temporary folder
    assert lib.read_bytes() == evil  # the untrusted folder was not written either
    # control: with the folder private again the planted library verifies and is loaded
    os.chmod(cache, 0o700)
    monkeypatch.setattr(codegen, "_LIBRARIES", {})
    assert codegen.build_shared_library(GOOD, "trustdir").answer() == 666
    assert marker.exists()


@needs_cc
def test_library_swapped_after_its_check_is_not_the_one_loaded(cache, tmp_path, monkeypatch):
    """The bytes verified are the bytes loaded: a file swapped on disk between the HMAC check
    and the load is not loaded (the check's own copy is, from a private temporary folder)."""
    import physid._paths

    _built_elsewhere("trustswap")
    (lib,) = cache.glob("trustswap-*.so")
    marker = tmp_path / "swapped-library-ran"
    evil = _evil_library(tmp_path, marker)
    read = physid._paths.read_private

    def read_then_swap(path):
        data = read(path)
        if str(path).endswith(".hmac"):  # the library was read already: swap it now
            lib.write_bytes(evil)
        return data

    monkeypatch.setattr(physid._paths, "read_private", read_then_swap)
    monkeypatch.setattr(codegen, "_LIBRARIES", {})
    loaded, load = [], codegen._load
    monkeypatch.setattr(codegen, "_load", lambda path: loaded.append(path) or load(path))
    assert codegen.build_shared_library(GOOD, "trustswap").answer() == 7
    assert not marker.exists()
    assert lib.read_bytes() == evil  # the swap happened, after the check
    (path,) = loaded
    assert os.path.basename(os.path.dirname(path)).startswith("physid-load-")
    assert not os.path.exists(os.path.dirname(path))  # the private copy is removed
