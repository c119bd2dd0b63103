"""Golden values (tests/golden/*.json), without their provenance notes."""

from __future__ import annotations

import json
from pathlib import Path

GOLDEN = Path(__file__).resolve().parent / "golden"


def golden(name: str) -> dict:
    """Read ``tests/golden/<name>.json``; every table loses its ``provenance`` key."""
    data = json.loads((GOLDEN / f"{name}.json").read_text(encoding="utf-8"))
    return {
        key: {k: v for k, v in value.items() if k != "provenance"}
        if isinstance(value, dict)
        else value
        for key, value in data.items()
    }


CEDRO = golden("cedro_janecki")
