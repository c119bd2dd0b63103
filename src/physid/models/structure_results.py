"""What a structure model's analyses return: the identifiability verdict and the modes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ModalParameters", "StructureIdentifiability"]


@dataclass(frozen=True)
class StructureIdentifiability:
    """Which physical parameters the chosen inputs and outputs determine.

    Attributes
    ----------
    identifiable : tuple of str
        Parameters determined by the input–output behaviour.
    unidentifiable : tuple of str
        Parameters that move along a direction leaving every output unchanged.
    directions : tuple of str
        Those directions in words (relative changes of the parameters that cancel).
    rank : int
        Rank of the Jacobian of the Markov parameters with respect to log θ.
    n_parameters : int
        Number of linear parameters checked.
    nonlinear : tuple of str
        Cubic-spring and friction parameters (not in the linear transfer function; determined
        when the data excite them).
    message : str
        The verdict in words.
    seconds : float
        Time taken [s].
    """

    identifiable: tuple
    unidentifiable: tuple
    directions: tuple
    rank: int
    n_parameters: int
    nonlinear: tuple
    message: str
    seconds: float


@dataclass(frozen=True)
class ModalParameters:
    """Natural frequencies, damping ratios and mode shapes of a linear structure.

    Attributes
    ----------
    frequency : ndarray, shape (n_modes,) [rad/s]
        Undamped natural frequencies ω_j = |λ_j|, ascending.
    damping : ndarray, shape (n_modes,)
        Damping ratios ζ_j = −Re λ_j / |λ_j|.
    shapes : ndarray, shape (n_nodes, n_modes)
        Mode shapes (displacement part of the eigenvectors), scaled so the largest entry of
        each column is 1 and rotated to be real where the damping is proportional.
    frequency_stderr, damping_stderr : ndarray or None
        Delta-method standard errors (None without a covariance).
    shapes_stderr : ndarray or None
        Standard errors of the real parts of the shapes.
    nodes : tuple of str
        Row names of ``shapes``.
    overdamped : int
        Number of real eigenvalues left out (overdamped motion).
    """

    frequency: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray
    nodes: tuple
    frequency_stderr: np.ndarray | None = None
    damping_stderr: np.ndarray | None = None
    shapes_stderr: np.ndarray | None = None
    overdamped: int = 0

    @property
    def frequency_hz(self) -> np.ndarray:
        """Natural frequencies f_j = ω_j / 2π [Hz]."""
        return self.frequency / (2 * np.pi)

    def summary(self) -> str:
        """One line per mode: frequency [Hz] ± se, damping ratio ± se, shape.

        Returns
        -------
        str
        """
        lines = [f"modes of {len(self.frequency)} (nodes {', '.join(self.nodes)}):"]
        for j in range(len(self.frequency)):
            f = f"{self.frequency_hz[j]:.6g} Hz"
            z = f"zeta {self.damping[j]:.4g}"
            if self.frequency_stderr is not None:
                f += f" ± {self.frequency_stderr[j] / (2 * np.pi):.2g}"
                z += f" ± {self.damping_stderr[j]:.2g}"
            shape = ", ".join(f"{v:+.4f}" for v in self.shapes[:, j].real)
            lines.append(f"  mode {j + 1}: {f}, {z}, shape [{shape}]")
        if self.overdamped:
            lines.append(f"  ({self.overdamped} real (overdamped) poles not listed)")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """JSON-ready: frequency [rad/s] and frequency_hz, damping, shapes (real parts), errors.

        Returns
        -------
        dict
        """

        def lst(a):
            return None if a is None else np.asarray(a).real.tolist()

        return {
            "nodes": list(self.nodes),
            "frequency": lst(self.frequency),
            "frequency_hz": lst(self.frequency_hz),
            "damping": lst(self.damping),
            "shapes": lst(self.shapes),
            "frequency_stderr": lst(self.frequency_stderr),
            "damping_stderr": lst(self.damping_stderr),
            "shapes_stderr": lst(self.shapes_stderr),
            "overdamped": self.overdamped,
        }
