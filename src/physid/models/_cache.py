"""On-disk cache of generated model code, keyed by a hash of the model's content.

One JSON file per entry, ``<cache dir>/<kind>-<key>.json``, holding the generated source text and
the metadata needed to rebuild a model without sympy. The folder is ``$PHYSID_CACHE_DIR`` if set,
else ``$XDG_CACHE_HOME/physid`` or ``~/.cache/physid``.

The key also covers a hash of the code-generating modules' source (`code_fingerprint`), so
editing them never serves stale code. Robustness: entries are written to a temporary file in
the same folder and moved into place with ``os.replace`` (atomic on POSIX and Windows), so a
reader never sees half a file; every entry records `CACHE_FORMAT` and its own key, and anything
unreadable, from another format, or with a mismatching key counts as a miss and is rebuilt (and
overwritten). A cache folder that cannot be written is not an error: the model is simply
derived again next time.

Trust: the cached data are Python source that `physid.models.codegen.source_to_function`
executes, so an entry is used only from a trusted folder (`physid._paths.trusted_cache`: owned by
the user, not writable by the group or others) and only if the entry file itself is a regular
file with the same owner and no group/other write permission. Every entry stores an HMAC-SHA256
of its kind, key and data (`entry_mac`), keyed with the folder's per-user secret; an entry whose
MAC does not match (edited, truncated, written by an older physid with a plain SHA-256, or by
someone who cannot read the key) is a miss: the code is derived again and the entry
overwritten, and the altered source never runs. An untrusted folder is neither read nor
written (one warning says why and how to fix it); the model is then derived in memory.
"""

from __future__ import annotations

import functools
import hashlib
import json
import sys
from pathlib import Path

from .._paths import atomic_write, cache_dir, cache_mac, read_private, same_mac, trusted_cache

__all__ = [
    "CACHE_FORMAT",
    "cache_dir",
    "content_key",
    "data_digest",
    "entry_mac",
    "load_entry",
    "save_entry",
    "cached",
]

#: Bump when the generated code or the metadata layout changes: old entries then miss.
CACHE_FORMAT = "physid-models-11"


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Hash of the code-generating modules' source: any edit to them misses the cache."""
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    # every module whose code shapes what is derived and generated (the chain's derivation and
    # symbolic description, the model-file reader that builds it)
    for name in (
        "lagrange.py",
        "codegen.py",
        "chain.py",
        "chain_derive.py",
        "chain_symbolic.py",
        "spec.py",
        "spec_types.py",
        "spec_chain.py",
    ):
        try:
            digest.update((here / name).read_bytes())
        except OSError:  # pragma: no cover - e.g. a zipped install; the format string still guards
            digest.update(name.encode())
    return digest.hexdigest()[:16]


def content_key(content) -> str:
    """SHA-256 of the canonical JSON of ``content``, cache format, code and Python version."""
    payload = json.dumps(
        {
            "format": CACHE_FORMAT,
            "code": code_fingerprint(),
            "python": list(sys.version_info[:2]),
            "content": content,
        },
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(payload.encode("utf-8")).hexdigest()[:32]


def data_digest(data) -> str:
    """SHA-256 (hex) of the canonical JSON of an entry's ``data``.

    Canonical: sorted keys, no spaces, so the digest of the data as written equals the digest of
    the same data read back from the file. Anyone can recompute it, so it is no integrity check:
    entries are verified with the keyed `entry_mac`.
    """
    return hashlib.sha256(_canonical(data).encode("utf-8")).hexdigest()


def _canonical(data) -> str:
    normal = json.loads(json.dumps(data))  # as read back: tuples → lists, keys → str
    return json.dumps(normal, sort_keys=True, separators=(",", ":"))


def entry_mac(secret: bytes, kind: str, key: str, data) -> str:
    """HMAC-SHA256 (hex) of an entry's kind, key and canonical ``data`` under the folder's key.

    Parameters
    ----------
    secret : bytes
        The cache folder's secret key (`physid._paths.trusted_cache`).
    kind, key : str
        The entry's name parts (a valid entry copied under another name does not verify).
    data : JSON-compatible
        The entry's data.

    Returns
    -------
    str
    """
    return cache_mac(
        secret, CACHE_FORMAT.encode(), kind.encode(), key.encode(), _canonical(data).encode()
    )


#: Entries this process derived but could not write (untrusted or unwritable folder): kept in
#: memory, so that a second load in the same process does not derive them again.
_MEMORY: dict[tuple[str, str], str] = {}


def load_entry(kind: str, key: str) -> dict | None:
    """Return the cached entry, or None on a miss (absent, unreadable, untrusted, stale)."""
    trusted = trusted_cache()
    data = None if trusted is None else _read_entry(*trusted, kind, key)
    if data is None and (kind, key) in _MEMORY:  # as JSON text: every load gets its own copy
        data = json.loads(_MEMORY[(kind, key)])
    return data


def _read_entry(folder: Path, secret: bytes, kind: str, key: str) -> dict | None:
    raw = read_private(folder / f"{kind}-{key}.json")
    if raw is None:
        return None
    try:
        entry = json.loads(raw.decode("utf-8"))
    except (ValueError, UnicodeDecodeError):
        return None
    if (
        not isinstance(entry, dict)
        or entry.get("format") != CACHE_FORMAT
        or entry.get("key") != key
    ):
        return None
    data = entry.get("data")
    if not isinstance(data, dict):
        return None
    try:
        mac = entry_mac(secret, kind, key, data)
    except (TypeError, ValueError):
        return None
    if not same_mac(mac, entry.get("hmac")):  # altered, or not written by this user: never run
        return None
    return data


def save_entry(kind: str, key: str, data: dict) -> bool:
    """Write an entry atomically (mode 0600); False if the folder is unwritable or untrusted.

    An entry that is not written is kept in this process's memory instead.
    """
    try:
        text = json.dumps(data)
    except (TypeError, ValueError):  # not JSON data: nothing to cache
        return False
    trusted = trusted_cache(create=True)
    if trusted is not None:
        folder, secret = trusted
        mac = entry_mac(secret, kind, key, data)
        entry = {"format": CACHE_FORMAT, "key": key, "hmac": mac, "data": data}
        try:
            atomic_write(folder / f"{kind}-{key}.json", lambda fh: json.dump(entry, fh), mode=0o600)
        except OSError:
            pass
        else:
            _MEMORY.pop((kind, key), None)
            return True
    _MEMORY[(kind, key)] = text
    return False


def cached(kind: str, key: str, derive, *, enabled: bool = True, valid=None) -> tuple[dict, bool]:
    """The entry ``kind``/``key`` if cached and ``valid(data)``, else ``derive()`` (then saved).

    Returns ``(data, hit)``; with ``enabled=False`` the cache is neither read nor written.
    """
    data = load_entry(kind, key) if enabled else None
    if data is not None and (valid is None or valid(data)):
        return data, True
    data = derive()
    if enabled:
        save_entry(kind, key, data)
    return data, False
