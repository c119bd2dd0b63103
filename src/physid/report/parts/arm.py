"""Part III of the report: a 6-DOF arm identified end to end (filled in below)."""

from __future__ import annotations

RENDERERS: dict = {}
