"""Fuzz `load_result` with mutations of a valid result file (deleted keys, wrong types, NaN,
huge numbers, nesting): it returns a `LoadedResult` whose parameters are finite numbers, or
raises a `PhysidError` — never another exception, never a value filled in silently.

``make fuzz`` runs it at 20 000 examples (profile ``fuzz`` in tests/conftest.py); the default
profile runs a few dozen.
"""

from __future__ import annotations

import json
import math
import tempfile
import warnings
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from physid.analysis.validation import LoadedResult, load_result
from physid.errors import PhysidError

_SETTINGS = settings(deadline=None, suppress_health_check=list(HealthCheck))

#: A result file of the algebraic estimator on the MSD, as save_result writes it (abridged).
_VALID = {
    "format": "physid-result", "format_version": 1, "method": "algebraic",
    "names": ["theta1", "theta2"], "parameters": {"theta1": 0.0188, "theta2": 133.43},
    "derived": {"natural_frequency": 11.55, "damping_ratio": 0.0008}, "stderr": None,
    "stderr_reason": "none", "units": {"theta1": "1/s", "theta2": "1/s^2"}, "success": True,
    "message": "", "known": {"b0": 1.0}, "window": 0.05, "settings": {"dt": 0.0004},
    "model": "msd", "model_options": {},
}  # fmt: skip

_LEAVES = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([1e308, -1e308, 1e151, 0.0]),
    st.text(max_size=8), st.sampled_from(["msd", "theta1", "physid-result", "rls", "idim-ols"]),
)  # fmt: skip
_VALUES = st.recursive(
    _LEAVES,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3),
        st.dictionaries(st.sampled_from(["theta1", "theta2", "b0", "dt", "x"]), inner, max_size=3),
    ),
    max_leaves=12,
)
_KEYS = st.sampled_from([*_VALID, "fixed", "columns", "free", "gains", "dt", "half_width",
                         "cutoff", "stick_threshold", "parameter_set", "model_name"])  # fmt: skip


@st.composite
def _mutated(draw):
    doc = json.loads(json.dumps(_VALID))
    for _ in range(draw(st.integers(min_value=0, max_value=4))):
        key = draw(_KEYS)
        action = draw(st.sampled_from(["delete", "replace", "param", "nest"]))
        if action == "delete":
            doc.pop(key, None)
        elif action == "replace":
            doc[key] = draw(_VALUES)
        elif action == "param" and isinstance(doc.get("parameters"), dict):
            name = draw(st.sampled_from(["theta1", "theta2", "b0"]))
            if draw(st.booleans()):
                doc["parameters"].pop(name, None)
            else:
                doc["parameters"][name] = draw(_LEAVES)
        else:
            depth = draw(st.integers(min_value=1, max_value=60))
            doc[key] = json.loads("[" * depth + "]" * depth)
    return doc


@_SETTINGS
@given(doc=_mutated(), cut=st.one_of(st.none(), st.integers(min_value=0, max_value=400)))
def test_load_result_returns_a_valid_result_or_raises_physid_error(doc, cut):
    text = json.dumps(doc)  # NaN and Infinity are written as JSON's NaN/Infinity extensions
    if cut is not None:
        text = text[:cut]
    path = Path(tempfile.mkdtemp(prefix="physid-fuzz-")) / "fit.json"
    path.write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            loaded = load_result(path)
        except PhysidError:
            return
    assert isinstance(loaded, LoadedResult)
    assert all(isinstance(v, float) and math.isfinite(v) for v in loaded.parameters.values())
    coefficients = loaded.coefficients  # every coefficient of the model: none filled in
    assert set(loaded.model.a_names + loaded.model.b_names) <= set(coefficients)
    assert all(abs(v) <= 1e150 for v in coefficients.values())
