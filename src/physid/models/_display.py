"""How a model shows itself in a notebook (``_repr_html_``): joints, parameters, units and,
where they are cheap, the identifiable combinations."""

from __future__ import annotations

import html


def model_html(model) -> str:
    """An HTML summary of a model: its kind, joints (or input → output) and nominal parameters.

    Parameters
    ----------
    model : ChainModel, RigidBodyModel or LinearODEModel
        Needs ``name``, ``parameters`` and ``units``; ``joint_names`` / ``joint_types`` or
        ``input_name`` / ``output_name`` where it has them.

    Returns
    -------
    str
        A ``<div>`` with a heading line, a parameter table and the identifiable combinations
        (`combinations_html`), every text HTML-escaped.
    """
    esc = html.escape
    kind = type(model).__name__
    names = getattr(model, "joint_names", None)
    if names:
        types = getattr(model, "joint_types", None) or ("",) * len(names)
        joints = ", ".join(
            f"{esc(str(n))}" + (f" ({esc(str(t))})" if t else "")
            for n, t in zip(names, types, strict=False)
        )
        what = f"{len(names)} joint{'s' if len(names) != 1 else ''}: {joints}"
    else:
        what = (
            f"input {esc(str(getattr(model, 'input_name', 'u')))} → output "
            f"{esc(str(getattr(model, 'output_name', 'x')))}, order {getattr(model, 'order', '?')}"
        )
    units = dict(getattr(model, "units", {}) or {})
    rows = "".join(
        f"<tr><td>{esc(str(k))}</td><td style='text-align:right'>{float(v):.6g}</td>"
        f"<td>{esc(str(units.get(k, '')))}</td></tr>"
        for k, v in dict(model.parameters).items()
    )
    return (
        f"<div><p style='margin:0.2em 0'><b>{esc(kind)}</b> {esc(repr(str(model.name)))} · "
        f"{what} · {len(model.parameters)} parameters (nominal values)</p>"
        "<table><thead><tr><th>parameter</th><th>nominal</th><th>unit</th></tr></thead>"
        f"<tbody>{rows}</tbody></table>{combinations_html(model)}</div>"
    )


def combinations_html(model) -> str:
    """The identifiable combinations of a model's parameters, where they are cheap to show.

    A rigid-body model (a URDF) computes its base parameters numerically in a fraction of a
    second and caches them (`RigidBodyModel.base_parameters`): they are listed, each name with
    its expression in the standard parameters. For other models (symbolic chains, linear ODEs)
    the check is symbolic and can take long, so the line says how to get it instead.

    Parameters
    ----------
    model : model
        A rigid-body model has ``regressor_names`` and ``base_parameters()``.

    Returns
    -------
    str
        A ``<details>`` block with a table of base parameters, a ``<p>`` naming
        ``physid model info`` (chains), or ``""`` (a linear ODE, no joints).
    """
    esc = html.escape
    if not getattr(model, "joint_names", None):
        return ""  # a linear ODE: its coefficients are the parameters themselves
    how = (
        "<p style='margin:0.4em 0'>Identifiable combinations (a symbolic check that can take "
        f"a while): <code>physid model info {esc(str(model.name))}</code>, or "
        "<code>physid.models.identifiability.structural_identifiability(model)</code>.</p>"
    )
    if getattr(model, "regressor_names", None) is None or not hasattr(model, "base_parameters"):
        return how
    from ..errors import PhysidError

    try:
        base = model.base_parameters()
    except (PhysidError, ValueError, ArithmeticError):
        return how
    rows = "".join(
        f"<tr><td>{esc(str(n))}</td><td><code>{esc(str(e))}</code></td></tr>"
        for n, e in zip(base.base_names, base.expressions, strict=True)
    )
    return (
        f"<details><summary>{base.n_base} identifiable combinations (base parameters) of the "
        f"{base.n_beta} standard parameters</summary>"
        "<table><thead><tr><th>base parameter</th><th>combination</th></tr></thead>"
        f"<tbody>{rows}</tbody></table></details>"
    )
