"""The NPZ reader (never unpickles: an object array is refused, not loaded)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...errors import DataFileError
from .variables import _finish, _from_mapping, _Source, _Var


def _read_npz(path: Path) -> _Source:
    # never allow_pickle: an object array in a .npz can run code when unpickled
    with open(path, "rb") as fh:
        magic = fh.read(6)
    if magic.startswith(b"\x93NUMPY"):
        raise DataFileError(
            f"{path}: holds a single .npy array, not an NPZ archive of named variables; save it "
            "with numpy.savez(path, t=..., x=...)."
        )
    if not magic.startswith((b"PK\x03\x04", b"PK\x05\x06")):
        raise DataFileError(
            f"{path}: not an NPZ file: it is not a zip archive (it starts with {magic!r}); the "
            "file is damaged or of another format. Write it with numpy.savez(path, t=..., "
            "x=...) or save the data as CSV."
        )
    try:  # the file object is ours, so a damaged archive cannot leak an open handle
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            items, refused = {}, {}
            for k in z.files:
                try:
                    items[k] = z[k]
                except ValueError as exc:
                    if "allow_pickle" in str(exc) or "Object arrays" in str(exc):
                        refused[k] = "a Python object array (physid never unpickles data)"
                    else:
                        raise
    except DataFileError:
        raise
    except (ValueError, OSError, EOFError, KeyError, RuntimeError, NotImplementedError) as exc:
        raise DataFileError(_npz_error(path, exc)) from None
    except Exception as exc:  # zipfile.BadZipFile, zlib.error, struct.error ... on damaged files
        raise DataFileError(_npz_error(path, exc)) from None
    metadata: dict = {}
    if "metadata" in items:
        try:
            loaded = json.loads(str(items["metadata"]))
            metadata = loaded if isinstance(loaded, dict) else {}
        except (ValueError, RecursionError):
            metadata = {}
    source = _from_mapping(path, items)
    for key, why in refused.items():
        source.variables[key] = _Var(key, None, "", "cell", why, -1)
    return _finish(source, metadata)


def _npz_error(path, exc) -> str:
    kind = type(exc).__name__
    detail = str(exc)
    if "pickle" in detail.lower():
        detail = "its content is not numeric arrays"
    return (
        f"{path}: not a readable NPZ file ({kind}: {detail}); the file is damaged, truncated or "
        "not made by numpy.savez. Write it again with numpy.savez(path, t=..., x=...) or save "
        "the data as CSV."
    )
