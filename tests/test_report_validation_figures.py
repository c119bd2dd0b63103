"""Figures that do not mislead: gaps where samples were dropped, the user's names and units,
measured / model / residual in their own panels with the fit, the physical parameters."""

from __future__ import annotations

import numpy as np
import pytest

import physid
from physid.estimators.registry import make
from physid.report.style import DROPPED_LABEL, shade_dropped
from physid.report.validation import channel_labels, plot_comparison, write_validation_plots
from physid.signals.recording import Recording
from physid.simulate.msd import simulate_msd


def test_dropped_samples_are_gaps_in_shaded_spans_not_zero():
    t = np.linspace(0.0, 1.0, 101)
    y = 10.0 + np.sin(6 * t)  # a load far from 0: a drawn 0 would be a lie
    y_hat = y + 0.01
    y[30:50] = np.nan  # dropped near rest
    y_hat[30:50] = np.nan
    fig = plot_comparison(t, {"tau2": (y, y_hat)}, "held out", labels={"tau2": "tau2 [N·m]"})
    top, low = fig.axes
    measured = top.get_lines()[0].get_ydata()
    assert np.isnan(measured[30:50]).all() and not np.any(measured[~np.isnan(measured)] == 0)
    labels = top.get_legend_handles_labels()[1]
    assert labels[0] == DROPPED_LABEL
    ok = ~np.isnan(y)
    fit = 100 * (1 - np.linalg.norm(y[ok] - y_hat[ok]) / np.linalg.norm(y[ok] - y[ok].mean()))
    assert f"model (fit {fit:.2f} %)" in labels
    assert top.get_ylabel() == "tau2 [N·m]"
    assert low.get_ylabel() == "residual [N·m]"
    residual = low.get_lines()[0].get_ydata()
    assert np.allclose(residual[ok], -0.01) and np.isnan(residual[30:50]).all()


def test_shade_dropped_counts_runs():
    from matplotlib.figure import Figure

    ax = Figure().add_subplot()
    dropped = np.zeros(20, bool)
    dropped[[2, 3, 4, 10, 18, 19]] = True
    assert shade_dropped(ax, np.arange(20.0), dropped) == 3
    assert ax.get_legend_handles_labels()[1] == [DROPPED_LABEL]


def test_axis_labels_use_the_users_columns_and_units():
    rec = Recording(
        np.arange(5) * 0.1,
        np.ones((5, 2)),
        ["u", "x"],
        units=["N", "mm"],
        metadata={"channel_map": {"u": "Force", "x": "x"}},
    )
    assert channel_labels(rec) == {"u": "u = Force [N]", "x": "x [mm]"}
    assert channel_labels(None) == {}


def test_validate_page_has_verdict_fit_and_captions(tmp_path):
    rec = simulate_msd(
        mass=3.0, damping=1.5, stiffness=1200.0, ratio=3.0, amplitude=100.0, snr_db=40, rng=3
    )
    result = make("rls", physid.load_model("msd")).fit(rec).result_
    from physid.analysis.validation import validate

    report = validate(result, rec)
    written = write_validation_plots(report, tmp_path / "v", recording=rec)
    page = (tmp_path / "v" / "index.html").read_text(encoding="utf-8")
    assert set(written) == {"inverse_model", "output_error", "residual", "index"}
    assert f"{report.fit_percent['x']:.2f} %" in page
    assert "(c) residual tests:" in page and report.residual["verdict"][:40] in page
    assert page.count("<figcaption>") == 3


@pytest.fixture(scope="module")
def force_fit():
    rec = simulate_msd(
        mass=3.0, damping=1.5, stiffness=1200.0, ratio=1.0, force_amplitude=1000, snr_db=40, rng=1
    )
    rec = Recording(rec.t, np.column_stack([rec["u"] * 3.0, rec["x"]]), ["u", "x"], ["N", "m"])
    return {
        m: make(m, physid.load_model("msd-force")).fit(rec).result_ for m in ("rls", "algebraic")
    }


@pytest.mark.parametrize("method", ["rls", "algebraic"])
def test_plot_shows_the_declared_physical_parameters(force_fit, method):
    res = force_fit[method]
    fig = res.plot(truth={"m": 3.0, "c": 1.5, "k": 1200.0})
    assert [ax.get_ylabel() for ax in fig.axes] == ["m [kg]", "c [N·s/m]", "k [N/m]"]
    for ax, name in zip(fig.axes, ("m", "c", "k"), strict=True):
        finals = [ln.get_ydata()[0] for ln in ax.get_lines() if ln.get_label().startswith("final")]
        assert finals == [pytest.approx(res.physical["values"][name])]
        history = ax.get_lines()[0].get_ydata()
        if method == "rls":  # RLS's history ends at its final value (the algebraic
            # estimator's per-window values scatter; its final value is pooled over them)
            tail = history[np.isfinite(history)][-5:]
            assert np.median(tail) == pytest.approx(res.physical["values"][name], rel=0.05)
    # the coefficients stay one keyword away
    coeffs = res.plot(physical=False) if method == "rls" else res.plot(names=list(res.names))
    assert any("theta" in ax.get_ylabel() or "θ" in ax.get_ylabel() for ax in coeffs.axes)
