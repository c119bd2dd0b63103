"""Which parameters (or combinations) the data and the model can determine.

The computations live in `physid.models.identifiability` (the first stage, so estimators can use
them); this module is their public home in the analysis stage.
"""

from ..models.identifiability import (
    Combination,
    IdentifiabilityWarning,
    NumericIdentifiability,
    StructuralIdentifiability,
    describe_direction,
    hold_plan,
    numeric_identifiability,
    raise_if_not_excited,
    structural_identifiability,
    svd_tall,
)

__all__ = [
    "IdentifiabilityWarning",
    "Combination",
    "StructuralIdentifiability",
    "NumericIdentifiability",
    "structural_identifiability",
    "numeric_identifiability",
    "hold_plan",
    "describe_direction",
    "raise_if_not_excited",
    "svd_tall",
]
