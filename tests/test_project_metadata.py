"""The project's metadata in pyproject.toml."""

from __future__ import annotations

from pathlib import Path


def test_pyproject_has_no_placeholder_urls():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib

    root = Path(__file__).resolve().parents[1]
    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    assert "urls" not in project  # no public repository exists: no invented links
    assert "invalid" not in (root / "pyproject.toml").read_text()
    assert project["authors"] and len(project["classifiers"]) >= 10
