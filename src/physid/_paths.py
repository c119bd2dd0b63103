"""Where physid keeps files between runs."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["cache_dir"]


def cache_dir() -> Path:
    """The on-disk cache folder (derived models, compiled right-hand sides).

    ``$PHYSID_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/physid`` or ``~/.cache/physid``. It is
    created on first write; a folder that cannot be written only costs a re-derivation.
    """
    env = os.environ.get("PHYSID_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "physid"
