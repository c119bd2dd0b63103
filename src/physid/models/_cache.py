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

Integrity: the cached data are Python source that `physid.models.codegen.source_to_function`
executes, so every entry stores the SHA-256 of its data's canonical JSON (`data_digest`) when it
is written, and an entry whose data no longer hash to it (edited, truncated, tampered with) is a
miss: the code is derived again and the entry overwritten, and the altered source never runs.
(The hash detects changes made without recomputing it; someone who can rewrite the cache folder
and the hash can also rewrite physid itself, so the folder must stay the user's own.)
"""

from __future__ import annotations

import functools
import hashlib
import json
import sys
from pathlib import Path

from .._paths import atomic_write, cache_dir

__all__ = [
    "CACHE_FORMAT",
    "cache_dir",
    "content_key",
    "data_digest",
    "load_entry",
    "save_entry",
    "cached",
]

#: Bump when the generated code or the metadata layout changes: old entries then miss.
CACHE_FORMAT = "physid-models-10"


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Hash of the code-generating modules' source: any edit to them misses the cache."""
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for name in ("lagrange.py", "codegen.py", "chain.py", "spec.py"):
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
    """SHA-256 (hex) of the canonical JSON of an entry's ``data`` (the integrity check).

    Canonical: sorted keys, no spaces, so the digest of the data as written equals the digest of
    the same data read back from the file.
    """
    normal = json.loads(json.dumps(data))  # as read back: tuples → lists, keys → str
    text = json.dumps(normal, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _path(kind: str, key: str) -> Path:
    return cache_dir() / f"{kind}-{key}.json"


def load_entry(kind: str, key: str) -> dict | None:
    """Return the cached entry, or None on a miss (absent, unreadable, corrupt, stale)."""
    path = _path(kind, key)
    try:
        with open(path, encoding="utf-8") as fh:
            entry = json.load(fh)
    except (OSError, ValueError, UnicodeDecodeError):
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
        digest = data_digest(data)
    except (TypeError, ValueError):
        return None
    if entry.get("sha256") != digest:  # altered since it was written: never run it
        return None
    return data


def save_entry(kind: str, key: str, data: dict) -> bool:
    """Write an entry atomically; return False (silently) if the folder is not writable."""
    try:
        digest = data_digest(data)
    except (TypeError, ValueError):  # not JSON data: nothing to cache
        return False
    entry = {"format": CACHE_FORMAT, "key": key, "sha256": digest, "data": data}
    try:
        atomic_write(_path(kind, key), lambda fh: json.dump(entry, fh))
    except OSError:
        return False
    return True


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
