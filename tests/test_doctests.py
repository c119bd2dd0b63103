"""Run the examples in every docstring under ``src/physid`` (``doctest`` with ELLIPSIS and
NORMALIZE_WHITESPACE, matplotlib on the Agg backend), so that documented examples cannot rot."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import matplotlib
import pytest

matplotlib.use("Agg")

import physid  # noqa: E402

MODULES = sorted(
    info.name
    for info in pkgutil.walk_packages(physid.__path__, prefix="physid.")
    if not info.name.endswith("__main__")
)


def test_every_module_is_collected():
    # a guard against the walk silently finding nothing (e.g. a broken package path)
    assert "physid.filters.differential" in MODULES
    assert "physid.signals.io" in MODULES
    assert "physid.models.chain" in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # examples that write files write them here
    monkeypatch.setenv("MPLBACKEND", "Agg")
    module = importlib.import_module(name)
    result = doctest.testmod(
        module,
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
        verbose=False,
        report=True,
    )
    assert result.failed == 0, (
        f"{result.failed} of {result.attempted} doctest example(s) failed in {name}"
    )
