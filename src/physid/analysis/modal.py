"""Modal analysis of identified structures: modes with errors, and frequency responses.

* `modal_parameters` — natural frequencies [rad/s], damping ratios and mode shapes of a
  structure model at given parameter values, with delta-method standard errors from a
  covariance (`physid.models.structure.StructureModel.modal`; an identified result's
  ``result.modal()`` calls the same).
* `frequency_response` — the model's H(jω) = C_s (jω I − A)⁻¹ B_s + D_s from every force to
  every output.
* `measured_frequency_response` — the H1 estimate S_yu / S_uu (Welch) from a recording, to plot
  against the model's (`FrequencyResponse.plot`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, arg

__all__ = [
    "modal_parameters",
    "frequency_response",
    "measured_frequency_response",
    "FrequencyResponse",
]


def modal_parameters(model, params=None, covariance=None, names=None):
    """Natural frequencies, damping ratios and mode shapes (see `StructureModel.modal`).

    Parameters
    ----------
    model : StructureModel
    params : mapping, optional
        Parameter values (default nominal).
    covariance : ndarray (p, p), optional
        Covariance of ``names`` for the delta method.
    names : sequence of str, optional
        Order of ``covariance``.

    Returns
    -------
    ModalParameters
    """
    return model.modal(params, covariance, names)


@dataclass(frozen=True)
class FrequencyResponse:
    """H(jω) of a structure, model or measured.

    Attributes
    ----------
    omega : ndarray (n_freq,) [rad/s]
    response : ndarray (n_freq, n_outputs, n_inputs), complex
        Output unit per N.
    outputs, inputs : tuple of str
        Channel names.
    label : str
        ``"model"`` or ``"measured"``.
    """

    omega: np.ndarray
    response: np.ndarray
    outputs: tuple
    inputs: tuple
    label: str = "model"

    @property
    def magnitude(self) -> np.ndarray:
        """|H| (n_freq, n_outputs, n_inputs)."""
        return np.abs(self.response)

    @property
    def phase(self) -> np.ndarray:
        """Unwrapped phase [rad] along frequency."""
        return np.unwrap(np.angle(self.response), axis=0)

    def plot(self, other=None, *, output: int = 0, input: int = 0, axes=None):
        """Magnitude and phase against frequency [Hz], with ``other`` (e.g. measured) overlaid.

        Parameters
        ----------
        other : FrequencyResponse, optional
        output, input : int
            Which entry of H.
        axes : pair of matplotlib Axes, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt

        if axes is None:
            fig, axes = plt.subplots(2, 1, sharex=True, figsize=(6.4, 4.8))
        else:
            fig = axes[0].figure
        for fr, style in ((self, "-"), (other, "--")):
            if fr is None:
                continue
            f = fr.omega / (2 * np.pi)
            axes[0].loglog(f, fr.magnitude[:, output, input], style, label=fr.label)
            axes[1].semilogx(f, np.degrees(fr.phase[:, output, input]), style, label=fr.label)
        axes[0].set_ylabel(f"|{self.outputs[output]} / {self.inputs[input]}|")
        axes[1].set_ylabel("phase [deg]")
        axes[1].set_xlabel("frequency [Hz]")
        axes[0].legend()
        return fig


def frequency_response(model, omega, params=None) -> FrequencyResponse:
    """The model's frequency response H(jω) = C_s (jωI − A)⁻¹ B_s + D_s.

    Parameters
    ----------
    model : StructureModel
    omega : array_like (n_freq,) [rad/s]
    params : mapping, optional

    Returns
    -------
    FrequencyResponse
    """
    omega = np.asarray(omega, dtype=float).ravel()
    A, Bs, Cs, Ds = model.state_space(params)
    eye = np.eye(A.shape[0])
    H = np.array([Cs @ np.linalg.solve(1j * w * eye - A, Bs) + Ds for w in omega])
    return FrequencyResponse(omega, H, tuple(model.output_names), tuple(model.input_names))


def measured_frequency_response(model, recording, *, segment: int = 4096) -> FrequencyResponse:
    """The H1 estimate Ŝ_yu(ω) / Ŝ_uu(ω) (Welch, Hann segments) of every output per force.

    Parameters
    ----------
    model : StructureModel
        Names the channels.
    recording : Recording
        Forces and outputs, uniformly sampled.
    segment : int
        Samples per Welch segment (frequency resolution fs/segment).

    Returns
    -------
    FrequencyResponse
        ``label = "measured"``; one input at a time (several forces need a MIMO estimate:
        the cross-spectral matrix, not done here).
    """
    from scipy.signal import csd, welch

    if len(model.input_names) != 1:
        raise InputError(
            f"measured_frequency_response handles one force; model {model.name!r} has "
            f"{list(model.input_names)}."
        )
    if recording.n_samples < segment:
        raise InputError(
            f"{arg('segment')} = {segment} exceeds the record's {recording.n_samples} samples."
        )
    fs = 1.0 / recording.dt
    u = recording[model.input_names[0]]
    f, Suu = welch(u, fs=fs, nperseg=segment)
    H = np.empty((f.size, len(model.output_names), 1), dtype=complex)
    for r, name in enumerate(model.output_names):
        H[:, r, 0] = csd(u, recording[name], fs=fs, nperseg=segment)[1] / np.where(
            Suu > 0, Suu, np.nan
        )
    keep = f > 0
    return FrequencyResponse(
        2 * np.pi * f[keep],
        H[keep],
        tuple(model.output_names),
        tuple(model.input_names),
        "measured",
    )
