"""Motor-side channels as joint-side ones, through a model's transmission, for a recording or
block by block.

A model with a ``[transmission]`` (`physid.models.transmission`) reads motor angles ``qm``,
motor torques ``taum`` or currents ``im`` and turns them into ``q1..qn`` and ``tau1..taun``
(``q = K⁻¹ θm``, ``τ = Kᵀ τm``): a conversion sample by sample, so the same for a whole
recording and for each block of a long one. Every reader of a log for a fit (the command line,
streamed fits, fleets) goes through `joint_side`.
"""

from __future__ import annotations

from .blocks import TransformedBlocks
from .recording import Recording

__all__ = ["joint_side", "joint_side_blocks"]


def joint_side(model, rec: Recording) -> Recording:
    """``rec`` with its motor-side channels converted by ``model``'s transmission.

    Parameters
    ----------
    model : model
        Any model; one without ``joint_side_channels`` (no transmission) leaves ``rec`` as is.
    rec : Recording

    Returns
    -------
    Recording
        ``rec`` itself when nothing converts, else a new recording with ``q1..qn`` [rad, m for
        a prismatic joint] and ``tau1..taun`` [N·m, N] added.
    """
    convert = getattr(model, "joint_side_channels", None)
    if convert is None:
        return rec
    source = str(rec.metadata.get("source") or "the recording")
    cols, units = convert(rec.names, rec.__getitem__, source)
    return rec.with_channels(cols, units) if cols else rec


def joint_side_blocks(model, source):
    """A block source whose blocks are converted by ``model``'s transmission (`joint_side`).

    Parameters
    ----------
    model : model
    source : BlockSource

    Returns
    -------
    BlockSource
        ``source`` itself for a model without a transmission.
    """
    if getattr(model, "joint_side_channels", None) is None:
        return source
    return TransformedBlocks(source, lambda rec: joint_side(model, rec))
