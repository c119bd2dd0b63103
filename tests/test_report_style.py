"""The one figure style (physid.report.style) and the estimators' plots that use it."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
from pathlib import Path

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from physid.report import style  # noqa: E402


def _luminance(colour) -> float:
    r, g, b = to_rgb(colour)
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def test_series_stay_distinct_in_grey_and_for_colour_blind_readers():
    n = len(style.COLORS)
    styles = [style.series_style(i) for i in range(n)]
    # every pair differs by its dash pattern, its marker or clearly by its grey level
    for i in range(n):
        for j in range(i + 1, n):
            a, b = styles[i], styles[j]
            grey_apart = abs(_luminance(a["color"]) - _luminance(b["color"])) > 0.08
            assert a["marker"] != b["marker"] and (
                a["linestyle"] != b["linestyle"] or grey_apart
            ), (i, j)
    assert len(set(style.COLORS)) == n
    # the Okabe–Ito blue, vermillion and bluish green lead the cycle
    assert style.COLORS[:3] == ("#0072B2", "#D55E00", "#009E73")


def test_robust_limits_follow_the_converged_part_not_the_transient():
    t = np.linspace(0.0, 10.0, 2001)
    trace = 1.5 + 400.0 * np.exp(-5.0 * t) * np.cos(20 * t)  # θ1 = 1.5 after a huge start-up
    low, high = style.robust_limits(trace, truth=1.5, final=trace[-1])
    assert low < 1.5 < high
    assert high - low < 0.01  # the −400…400 transient does not set the axis
    # the truth stays in view even when the estimate converged elsewhere
    low, high = style.robust_limits(np.full(100, 2.0), truth=1.0)
    assert low < 1.0 and high > 2.0
    assert style.robust_limits([np.nan, np.inf]) is None


def test_legend_outside_does_not_cover_the_data():
    @style.styled
    def draw():
        fig = Figure(figsize=(style.FULL_WIDTH, style.panel_height()), layout="constrained")
        ax = fig.add_subplot()
        ax.plot([0, 1], [0, 1], label="a")
        ax.plot([0, 1], [1, 0], label="b")
        style.legend_outside(ax)
        return fig, ax

    fig, ax = draw()
    fig.canvas.draw()
    legend = ax.get_legend().get_window_extent()
    axes = ax.get_window_extent()
    assert legend.x0 >= axes.x1 - 1  # entirely to the right of the data area
    assert style.legend_outside(Figure().add_subplot()) is None  # nothing labelled


def test_save_figure_writes_one_png_at_the_one_dpi(tmp_path):
    fig = Figure(figsize=(2.0, 1.0))
    fig.add_subplot().plot([0, 1])
    path = style.save_figure(fig, tmp_path / "f.png")
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["f.png"]  # atomic: no temporary left
    width = int.from_bytes(data[16:20], "big")
    assert width == pytest.approx(2.0 * style.DPI, abs=0.2 * style.DPI)  # tight bbox trims


def test_describe_figure_reads_shared_labels_and_skips_colour_bars():
    fig = Figure()
    axes = fig.subplots(2, 1, sharex=True)
    for ax in axes:
        image = ax.imshow(np.eye(3))
        ax.set_ylabel("y [m]")
    axes[1].set_xlabel("t [s]")
    fig.colorbar(image, ax=list(axes))
    fig.suptitle("Two panels")
    info = style.describe_figure(fig)
    assert info["title"] == "Two panels"
    assert [a["xlabel"] for a in info["axes"]] == ["t [s]", "t [s]"]  # the colour bar is left out


def test_rls_plot_sets_limits_by_the_converged_part_and_draws_final_and_truth():
    from physid.estimators import RecursiveLeastSquares
    from physid.simulate import msd_paper_scenario

    rec = msd_paper_scenario(ratio=1.0, snr_db=50.0, duration=2.0, seed=1)
    result = RecursiveLeastSquares("msd").fit(rec).result_
    truth = {"theta2": 400.0 / 3.0}
    fig = result.plot(truth=truth)
    theta2 = fig.axes[1]
    labels = [line.get_label() for line in theta2.lines]
    assert any(lbl.startswith("final estimate") for lbl in labels)
    assert any(lbl.startswith("true value") for lbl in labels)
    values = result.estimates[:, 1]
    finite = values[np.isfinite(values)]
    low, high = theta2.get_ylim()
    assert low <= truth["theta2"] <= high
    assert high - low < 0.5 * np.ptp(finite)  # not stretched by the start-up transient
    assert theta2.get_legend() is not None


def _toy_trial(settings, seed):
    return {"mean": float(np.random.default_rng(seed).normal(settings["mu"], 1.0, 50).mean())}


def test_sweep_and_validation_figures_go_through_save_figure(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    import physid.report.style as style
    from physid.analysis.montecarlo import run_sweep
    from physid.analysis.sweep_table import write_sweep
    from physid.report.style import figure_png

    saved = []
    real = style.save_figure

    def spy(fig, path):
        saved.append(Path(path).name)
        return real(fig, path)

    monkeypatch.setattr(style, "save_figure", spy)
    res = run_sweep(_toy_trial, {"mu": [0.0, 1.0]}, trials=2, seed=1, scheduler="serial",
                    progress=False)  # fmt: skip
    fig = Figure(figsize=(3, 2))
    fig.add_subplot().plot([0, 1], [0, 1])
    paths = write_sweep(res, tmp_path, figures={"toy": fig})
    assert saved == ["toy.png"]
    assert paths["figure:toy"].read_bytes() == figure_png(fig)  # style.DPI, tight bounding box
