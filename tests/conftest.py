"""Shared test configuration: no GUI backend, a fresh model cache per session."""

from __future__ import annotations

import os

import matplotlib
import pytest

matplotlib.use("Agg")


@pytest.fixture(scope="session", autouse=True)
def _isolated_cache(tmp_path_factory):
    """Point physid's on-disk derivation cache at a per-session folder."""
    old = os.environ.get("PHYSID_CACHE_DIR")
    os.environ["PHYSID_CACHE_DIR"] = str(tmp_path_factory.mktemp("physid-cache"))
    yield
    if old is None:
        os.environ.pop("PHYSID_CACHE_DIR", None)
    else:
        os.environ["PHYSID_CACHE_DIR"] = old
