"""What an object says it is: plain ``repr`` and the notebook's ``_repr_html_``."""

from __future__ import annotations

import html.parser
import re

import numpy as np
import pytest

import physid
from physid.estimators.registry import make
from physid.simulate.msd import simulate_msd


class _Cells(html.parser.HTMLParser):
    """The text of each table cell, row by row (and a check that the HTML nests)."""

    def __init__(self):
        super().__init__()
        self.rows, self.stack, self._cell = [], [], None

    def handle_starttag(self, tag, attrs):
        self.stack.append(tag)
        if tag == "tr":
            self.rows.append([])
        if tag in ("td", "th"):
            self._cell = ""

    def handle_endtag(self, tag):
        assert self.stack and self.stack[-1] == tag, (self.stack, tag)
        self.stack.pop()
        if tag in ("td", "th"):
            self.rows[-1].append(self._cell)
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


def _cells(text):
    p = _Cells()
    p.feed(text)
    p.close()
    assert p.stack == []
    return p.rows


@pytest.fixture(scope="module")
def record():
    return simulate_msd(
        mass=3.0, damping=0.15, stiffness=1200.0, ratio=1.0, amplitude=1000 / 3, snr_db=40, rng=1
    )


def test_rls_result_repr_names_values_errors_units_and_fit(record):
    res = make("rls", physid.load_model("msd")).fit(record).result_
    text = repr(res)
    assert text.startswith("RecursiveResult(rls, success: theta1 = ")
    assert re.search(r"theta2 = 400\.\d+ ± [0-9.e-]+ \[1/s\^2\]", text)
    assert text.endswith(f"; fit {res.fit_percent:.2f} %)")
    assert "array(" not in text and len(text) < 300  # not every sample of the history
    rows = _cells(res._repr_html_())
    assert rows[0] == ["parameter", "value", "stderr", "95 % interval", "unit", ""]
    theta2 = next(r for r in rows if r[0] == "theta2")
    lo, hi = (float(x) for x in theta2[3].strip("[]").split(","))
    se = res.stderr["theta2"]
    # the 95 % interval is value ± 1.96 se
    assert lo == pytest.approx(res.parameters["theta2"] - 1.959964 * se, rel=1e-5)
    assert hi == pytest.approx(res.parameters["theta2"] + 1.959964 * se, rel=1e-5)
    assert theta2[4] == "1/s^2"
    assert any(r[0] == "natural_frequency" and r[5] == "derived" for r in rows[1:])
    assert f"fit {res.fit_percent:.2f} %" in res._repr_html_()
    assert f"fit {res.fit_percent:.2f} %" in res.summary()


def test_result_without_errors_says_why_and_escapes_text(record):
    res = make("algebraic", physid.load_model("msd"), final="median").fit(record).result_
    out = res._repr_html_()
    assert res.stderr is None
    assert "no standard errors" in out
    assert all(r[2] == "—" for r in _cells(out)[1:])
    assert "<script" not in out


def test_recording_repr_has_rate_and_html_has_ranges(record):
    assert repr(record) == (
        "Recording(5001 samples, 0..5 s at 1 kHz; u [m/s^2], x [m], x_true [m])"
    )
    rows = _cells(record._repr_html_())
    assert rows[0] == ["channel", "unit", "min", "max"]
    u = next(r for r in rows if r[0] == "u")
    assert u[1] == "m/s^2"
    assert float(u[3]) == pytest.approx(float(np.max(record["u"])), rel=1e-3)
    assert "5 s at 1 kHz, 3 channels" in record._repr_html_()


@pytest.mark.parametrize("name", ["msd", "manipulator"])
def test_model_html_lists_parameters_with_units(name):
    model = physid.load_model(name)
    out = model._repr_html_()
    rows = _cells(out)
    assert [r[0] for r in rows[1:]] == list(model.parameters)
    for r in rows[1:]:
        assert float(r[1]) == pytest.approx(model.parameters[r[0]], rel=1e-5)
        assert r[2] == model.units.get(r[0], "")
    if name == "manipulator":
        assert "4 joints" in out
    else:
        assert "input u → output x, order 2" in out


def test_rigid_model_html_lists_its_base_parameters_and_a_chain_says_how_to_get_them():
    arm = physid.load_model("arm6")
    base = arm.base_parameters()
    out = arm._repr_html_()
    assert f"{base.n_base} identifiable combinations (base parameters) of the 78 standard" in out
    assert base.n_base == 52  # the 6-DOF arm's 78 standard parameters regroup into 52
    combos = out[out.index("<details>") : out.index("</details>") + len("</details>")]
    rows = _cells(combos)
    assert rows[0] == ["base parameter", "combination"]
    assert [r[0] for r in rows[1:]] == list(base.base_names)
    assert [r[1] for r in rows[1:]] == list(base.expressions)
    assert rows[1][0] == "ZZ1R" and rows[1][1].startswith("ZZ1 + Ia1 + ")
    chain = physid.load_model("manipulator")._repr_html_()
    assert "<details>" not in chain
    assert "<code>physid model info manipulator</code>" in chain
    assert "combinations" not in physid.load_model("msd")._repr_html_()
