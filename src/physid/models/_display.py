"""How a model shows itself in a notebook (``_repr_html_``): joints, parameters, units."""

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
        A ``<div>`` with a heading line and a parameter table (every text HTML-escaped).
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
        f"<tbody>{rows}</tbody></table></div>"
    )
