"""Figures of recordings and filters: right type, right number of lines, correct data."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure

from physid.errors import InputError
from physid.filters import design_filter, filter_derivatives
from physid.report.figures import plot_recording
from physid.report.filters import (
    derivative_demo_figure,
    plot_derivative_estimates,
    plot_frequency_responses,
)
from physid.signals import Recording


@pytest.fixture
def rec():
    t = 0.01 * np.arange(100)
    data = np.column_stack([np.sin(t), np.cos(t), t])
    return Recording(t, data, ("q1", "q2", "tau1"), ("rad", "rad", "N·m"))


def test_plot_recording_groups_by_unit(rec):
    fig = rec.plot()
    assert isinstance(fig, Figure)
    axes = fig.axes
    assert len(axes) == 2  # rad and N·m
    assert [len(ax.lines) for ax in axes] == [2, 1]
    np.testing.assert_array_equal(axes[0].lines[1].get_ydata(), rec["q2"])
    assert axes[1].get_ylabel() == "[N·m]"


def test_plot_recording_on_given_axes_and_subset(rec):
    fig = Figure()
    ax = fig.subplots()
    assert plot_recording(rec, names=["tau1"], ax=ax) is fig
    assert len(ax.lines) == 1 and ax.lines[0].get_label() == "tau1 [N·m]"
    with pytest.raises(InputError, match=r"lacks channel\(s\) \['x'\]"):
        plot_recording(rec, names=["x"])


def test_frequency_response_figure():
    filters = [design_filter(k, 50, 0.3, 1e-3) for k in ("lowpass", "first", "second")]
    omega = np.linspace(0.01, np.pi, 500)
    fig = plot_frequency_responses(filters, omega)
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    # designed, ideal, and the two vertical lines at Ω_g and 1.5 Ω_g
    assert [len(ax.lines) for ax in fig.axes] == [4, 4, 4]
    designed = fig.axes[1].lines[0].get_ydata()
    np.testing.assert_allclose(
        designed, 20 * np.log10(np.abs(filters[1].frequency_response(omega)))
    )
    with pytest.raises(InputError, match="at least one filter"):
        plot_frequency_responses([])


def test_derivative_figures():
    t = 1e-3 * np.arange(600)
    x = np.sin(5 * t)
    result = filter_derivatives(x, t, 50, 0.2)
    fig = plot_derivative_estimates(t, x, result, {"first": 5 * np.cos(5 * t)})
    assert [len(ax.lines) for ax in fig.axes] == [2, 2, 1]
    np.testing.assert_array_equal(fig.axes[1].lines[1].get_xdata(), result.t)
    demo = derivative_demo_figure(duration=0.5)
    assert [len(ax.lines) for ax in demo.axes] == [3, 2, 2]
