"""physid.models: what the system is — symbolic equations of motion turned into fast numeric code.

* `load_model` — ``"manipulator"`` (Cedro & Janecki's 4-DOF arm), ``"msd"`` (Oueslati et al.'s
  mass–spring–damper) or a TOML model file (``docs/model-files.md``).
* `ChainModel` — serial manipulators: inverse/forward dynamics, mass matrix, bias and gravity
  torques, ∂τ/∂θ, the regressor form τ = Y β(θ), base parameters, and fast single-state
  right-hand sides for ODE integrators (`ChainModel.make_rhs`, `make_state_rhs`; the PD closed
  loop is `physid.simulate.pd.pd_rhs`, which fuses its law in through `scalar_factory`).
* `LinearODEModel` — Σ a_i y^(i) = Σ b_i u^(i), with the MSD conversions.
"""

from __future__ import annotations

from .chain import BaseParameters, ChainModel, build_chain_model
from .library import BUILTIN_MODELS, load_model, load_model_file, manipulator_model, model_from_spec
from .linear_ode import (
    LinearODEModel,
    msd_from_physical,
    msd_model,
    natural_frequency_damping,
    physical_from_theta,
    theta_from_natural,
)
from .rigid import RigidChain
from .rigid_model import RigidBodyModel
from .spec import ChainSpec, JointSpec, LinearODESpec, ParameterSpec, dh_transform

__all__ = [
    "load_model",
    "load_model_file",
    "model_from_spec",
    "RigidBodyModel",
    "RigidChain",
    "BUILTIN_MODELS",
    "ChainModel",
    "BaseParameters",
    "build_chain_model",
    "manipulator_model",
    "LinearODEModel",
    "msd_model",
    "msd_from_physical",
    "natural_frequency_damping",
    "theta_from_natural",
    "physical_from_theta",
    "dh_transform",
    "ChainSpec",
    "JointSpec",
    "ParameterSpec",
    "LinearODESpec",
]
