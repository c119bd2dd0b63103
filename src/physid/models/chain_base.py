"""The base parameters of a chain: which combinations of its parameters τ = Y β(θ) determines."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

__all__ = ["BaseParameters"]


@dataclass(frozen=True)
class BaseParameters:
    """Which combinations of the parameters the equations of motion can determine.

    τ = Y(q, q̇, q̈) β(θ); the columns of Y are linearly dependent, so only ``n_base``
    combinations ``base = K β`` are identifiable (found by QR with column pivoting on Y at random
    states). On top of that, ``theta_rank`` says how many directions of θ itself the base
    parameters pin down at the nominal θ (rank of ∂base/∂θ).

    Attributes
    ----------
    beta_names : tuple of str
        Monomials β of the parameters, e.g. ``"m2*l2**2"``.
    n_beta, n_base : int
        Number of monomials and of base parameters (identifiable combinations).
    base_names : tuple of str
        Each base parameter written as a combination of monomials.
    base_matrix : ndarray (n_base, n_beta)
        K in base = K β.
    independent : tuple of str
        The monomials chosen as the leading term of each base parameter.
    no_effect : tuple of str
        Monomials that appear in the energies but cancel out of τ.
    parameter_names : tuple of str
        θ, in model order.
    theta_rank : int
        Rank of ∂base/∂θ at the nominal parameters (≤ len(parameter_names)).
    unidentifiable : tuple of str
        Plain-language statements, e.g. "m1 and l1 enter only as m1*l1**2: only that product can
        be identified".
    null_directions : ndarray (n_theta, n_theta - theta_rank)
        Relative changes dθ/θ that leave every base parameter unchanged (to first order).
    combinations : tuple of Combination
        The same statements as `physid.models.identifiability.Combination` objects (the one way
        physid names unidentifiable combinations; ``unidentifiable`` holds their texts).
    """

    beta_names: tuple
    n_beta: int
    n_base: int
    base_names: tuple
    base_matrix: np.ndarray
    independent: tuple
    no_effect: tuple
    parameter_names: tuple
    theta_rank: int
    unidentifiable: tuple
    null_directions: np.ndarray
    combinations: tuple = ()

    @property
    def expressions(self) -> tuple:
        """Each base parameter as a combination of the monomials (same as `base_names`)."""
        return self.base_names

    @property
    def description(self) -> str:
        """Human-readable summary (same as `summary`)."""
        return self.summary()

    def summary(self) -> str:
        """Multi-line text: the count, each base parameter, and what cannot be identified."""
        lines = [
            f"{self.n_base} base parameters (identifiable combinations) out of {self.n_beta} "
            f"monomials; θ-rank {self.theta_rank} of {len(self.parameter_names)} parameters.",
        ]
        lines += [f"  {name}" for name in self.base_names]
        if self.no_effect:
            lines.append(f"  no effect on τ: {', '.join(self.no_effect)}")
        lines += [f"  {s}" for s in self.unidentifiable]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """JSON-ready dictionary (arrays become nested lists)."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name == "combinations":
                v = [dataclasses.asdict(c) for c in v]
            out[f.name] = (
                v.tolist()
                if isinstance(v, np.ndarray)
                else (list(v) if isinstance(v, tuple) else v)
            )
        return out


def _format_combination(coeffs, names) -> str:
    terms = []
    for c, name in zip(coeffs, names, strict=False):
        if abs(c) < 1e-9:
            continue
        if abs(c - 1) < 1e-9:
            terms.append(f"+ {name}")
        elif abs(c + 1) < 1e-9:
            terms.append(f"- {name}")
        else:
            terms.append(f"{'-' if c < 0 else '+'} {abs(c):.6g}*{name}")
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else text
