"""Every public name has a numpydoc docstring with its sections.

Public names are the ``__all__`` of ``physid`` and of every subpackage (the curated API the
docs name). For each function or class the test parses the docstring with numpydoc
(`numpydoc.docscrape`, and `numpydoc.validate` for whether a function returns something) and
fails on:

* no docstring (``__doc__`` None or empty: e.g. one built by string concatenation);
* a function or method-like callable with parameters but no ``Parameters`` section;
* a function that returns a value (numpydoc's check, RT01) but has no ``Returns``/``Yields``;
* a class whose constructor takes arguments but whose docstring (or ``__init__``'s) has neither
  ``Parameters`` nor ``Attributes`` (dataclasses document their fields as either);
  exception classes need only a docstring (they take a message).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import warnings

import numpydoc.docscrape as docscrape
import pytest
from numpydoc.validate import validate

import physid


def _public_names():
    modules = ["physid"] + sorted(
        m.name for m in pkgutil.walk_packages(physid.__path__, "physid.") if m.ispkg
    )
    seen, out = set(), []
    for module_name in modules:
        module = importlib.import_module(module_name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if not (inspect.isclass(obj) or inspect.isfunction(obj)) or id(obj) in seen:
                continue  # constants, modules and instances carry no docstring of their own
            seen.add(id(obj))
            out.append(f"{module_name}.{name}")
    return out


NAMES = _public_names()


def _resolve(path):
    module_name, _, name = path.rpartition(".")
    return getattr(importlib.import_module(module_name), name)


def _parameters(func, *, skip_first=False):
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):
        return []
    params = list(sig.parameters.values())
    if skip_first and params:
        params = params[1:]
    return [p.name for p in params]


def _problems(path):
    obj = _resolve(path)
    doc = inspect.getdoc(obj)
    if not doc or not doc.strip():
        return ["no docstring (__doc__ is None or empty)"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpydoc warns about sections it does not know
        if inspect.isclass(obj):
            parsed = docscrape.ClassDoc(obj, config={"show_class_members": False})
        else:
            parsed = docscrape.FunctionDoc(obj)
    problems = []
    if inspect.isclass(obj):
        if issubclass(obj, BaseException):
            return []
        init_doc = inspect.getdoc(obj.__init__) if "__init__" in vars(obj) else ""
        sections = parsed["Parameters"] or parsed["Attributes"]
        if not sections and init_doc:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sections = docscrape.NumpyDocString(init_doc)["Parameters"]
        takes = (
            dataclasses.fields(obj)
            if dataclasses.is_dataclass(obj)
            else _parameters(obj.__init__, skip_first=True)
        )
        takes = [t for t in takes if getattr(t, "name", t) not in ("args", "kwargs")]
        if takes and not sections:
            problems.append("a constructor with arguments but no Parameters/Attributes section")
        return problems
    if _parameters(obj) and not parsed["Parameters"]:
        problems.append(f"parameters {_parameters(obj)} but no Parameters section")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        codes = {code for code, _ in validate(path)["errors"]}
    if "RT01" in codes or "YD01" in codes:
        problems.append("returns a value but has no Returns (or Yields) section")
    return problems


@pytest.mark.parametrize("path", NAMES)
def test_public_name_has_a_numpydoc_docstring(path):
    assert not _problems(path), f"{path}: " + "; ".join(_problems(path))


def test_the_check_covers_the_api_and_catches_defects():
    assert len(NAMES) > 100 and "physid.load_model" in NAMES

    def undocumented(x):
        return x

    def no_sections(x):
        """Return x."""
        return x

    for func in (undocumented, no_sections):
        globals()[func.__name__] = func
        try:
            assert _problems(f"{__name__}.{func.__name__}")
        finally:
            del globals()[func.__name__]
