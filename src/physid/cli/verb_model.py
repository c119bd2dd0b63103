"""``physid model info MODEL [--json]``: what a model is — joints, parameters, limits, base set.

Works for the built-ins (``manipulator``, ``msd``, ``arm6``), TOML model files, URDF sidecars and
URDF files. Prints text (or one JSON object with ``--json``); the load/derivation time is part of
it. Progress and timings go to stderr.
"""

from __future__ import annotations

import math
import time

from ._common import print_json, progress

ORDER = 15


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "model",
        help="describe a model: joints, parameters with units, limits, base parameters",
        description=(
            "Inspect a model: physid model info MODEL [--json]. MODEL is a built-in name "
            "(manipulator, msd, arm6), a .toml model file, a URDF sidecar or a .urdf file."
        ),
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    info = actions.add_parser(
        "info",
        help="joints, parameters, limits and base parameters of a model",
        description="Describe MODEL: joints, parameters with units, limits, base parameters "
        "(each as an expression of the standard parameters and in words) and the load time.",
    )
    info.add_argument("model", metavar="MODEL", help="built-in name, .toml or .urdf file")
    info.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    info.add_argument(
        "--no-base",
        action="store_true",
        help="skip the base parameters (they need the regressor; slow for big symbolic models)",
    )
    info.add_argument(
        "--base",
        action="store_true",
        help="compute the base parameters even when their estimated work is above the limit "
        "(a QR of about 1e10 floating-point operations: minutes for 100+ joints)",
    )
    info.set_defaults(func=run_info)


#: Estimated floating-point work of the base-parameter QR above which ``model info`` skips it
#: unless ``--base`` is given (about a minute on a busy laptop core; 2e9 took 7 s for a 50-joint
#: chain on a shared 2-core machine, and the work grows as the cube of the joints).
BASE_WORK_LIMIT = 2e10
#: Estimated work above which a progress line says what is being computed.
BASE_WORK_NOTE = 1e9


def base_work(model) -> tuple[int, int, float]:
    """``(rows, columns, flop)`` of the QR that finds a chain model's base parameters.

    The regressor stacks ``max(60, 2·columns/joints + 20)`` random states of every joint (as
    `physid.models.base.base_parameters_of_regressor` does); two column-pivoted QRs and a
    least-squares solve cost about ``3·rows·columns²``.
    """
    nj = max(int(model.n_joints), 1)
    cols = len(getattr(model, "regressor_names", None) or model.parameter_names)
    rows = max(60, 2 * cols // nj + 20) * nj
    return rows, cols, 3.0 * rows * cols**2


def _base_section(model, force: bool) -> dict:
    """The ``base_parameters`` section, or ``{"skipped": reason}`` when it is not computed."""
    from ..errors import IdentifiabilityError

    rows, cols, work = base_work(model)
    if work > BASE_WORK_LIMIT and not force:
        reason = (
            f"skipped: {cols} regressor columns need a QR of a {rows}×{cols} matrix (about "
            f"{work:.1e} floating-point operations, minutes or more); pass --base to compute "
            "them anyway (the result is cached)"
        )
        progress(f"physid model info: base parameters {reason}")
        return {"skipped": reason}
    if work > BASE_WORK_NOTE:
        progress(
            f"physid model info: computing the base parameters: QR of a {rows}×{cols} regressor "
            f"(about {work:.1e} floating-point operations) ..."
        )
    start = time.perf_counter()
    try:
        bp = model.base_parameters()
    except IdentifiabilityError:
        reason = (
            f"not available: model {model.name!r} is not polynomial in its parameters (an "
            "expression such as Abs(), sqrt() or a division by a parameter), so it has no "
            "linear-in-parameters form τ = Y β(θ); the IDIM methods need that form, the "
            "input-error method does not"
        )
        progress(f"physid model info: base parameters {reason}")
        return {"skipped": reason}
    exprs = getattr(bp, "expressions", bp.base_names)
    words = getattr(bp, "words", None) or [""] * len(exprs)
    return {
        "n_base": int(bp.n_base),
        "n_columns": int(bp.n_beta),
        "base": [
            {"name": b, "expression": e, "words": w}
            for b, e, w in zip(bp.base_names, exprs, words, strict=True)
        ],
        "no_effect": list(bp.no_effect),
        "unidentifiable": list(bp.unidentifiable),
        "seconds": time.perf_counter() - start,
    }


def _finite(x):
    x = float(x)
    return x if math.isfinite(x) else None


def describe(model, *, base: bool = True, force: bool = False) -> dict:
    """JSON-ready description of a model (the content of ``physid model info --json``).

    Parameters
    ----------
    model : ChainModel or LinearODEModel
    base : bool
        Include the base parameters (``{"skipped": reason}`` when their estimated work is above
        `BASE_WORK_LIMIT`, or when the model is not linear in its parameters).
    force : bool
        Compute the base parameters whatever their estimated work.

    Returns
    -------
    dict
    """
    from ..models import ChainModel

    out = {"name": model.name, "kind": type(model).__name__}
    if hasattr(model, "nodes"):  # a structure: nodes, channels and identifiability
        ident = model.identifiability()
        out["parameters"] = [
            {"name": k, "value": v, "unit": model.units.get(k, ""), "identify": k in model.unknown}
            for k, v in model.parameters.items()
        ]
        out.update(nodes=list(model.nodes), inputs=list(model.input_names))
        out["bases"] = dict(zip(model.base_nodes, model.base_names, strict=True))
        out["outputs"] = list(model.output_names)
        out["identifiability"] = {
            "identifiable": list(ident.identifiable),
            "unidentifiable": list(ident.unidentifiable),
            "directions": list(ident.directions),
            "message": ident.message,
            "seconds": ident.seconds,
        }
        return out
    units = dict(getattr(model, "units", {}))
    params = model.parameters
    if not isinstance(model, ChainModel):
        from ..estimators._linear import coefficient_units

        units.update(coefficient_units(model, model.coefficient_names))
    out["parameters"] = [
        {"name": k, "value": v, "unit": units.get(k, ""), "identify": k in model.unknown}
        for k, v in params.items()
    ]
    if isinstance(model, ChainModel):
        n = model.n_joints
        types = getattr(model, "joint_types", ("revolute",) * n)
        limits = getattr(model, "limits", None)
        joints = []
        for j in range(n):
            entry = {"index": j + 1, "name": model.joint_names[j], "type": types[j]}
            if limits is not None:
                lo, hi = limits["position"][j]
                entry["limits"] = {
                    "position": [_finite(lo), _finite(hi)],
                    "velocity": _finite(limits["velocity"][j]),
                    "effort": _finite(limits["effort"][j]),
                    "acceleration": _finite(limits["acceleration"][j]),
                }
            joints.append(entry)
        out["joints"] = joints
        out["gravity"] = list(model.gravity)
        out["load_seconds"] = float(model.load_seconds)
        out["loaded_from_cache"] = bool(model.loaded_from_cache)
        if base:
            out["base_parameters"] = _base_section(model, force)
    else:
        out["order"] = int(model.order)
        out["a"] = list(model.a_names)
        out["b"] = list(model.b_names)
        if model.expressions:
            out["physical"] = _physical(model, out["parameters"])
    return out


def _physical(model, entries) -> dict:
    """What the estimators give of a model in physical terms (``a = ["k/m", "c/m"]``).

    Marks each entry of ``entries`` (the parameter list, in place): a coefficient gets its
    ``expression``; a physical parameter to identify ``identify`` True and ``identifiable``
    (whether the estimated coefficients determine it). Returns the ``physical`` section of
    ``model info --json``: ``identifiable``, ``unidentifiable``, ``combinations`` (the expressions
    that are estimated) and ``message``.
    """
    ident = model.physical_identifiability()
    estimated = [c for c in model.coefficient_names if c in model.unknown]
    combos = [f"{c} = {model.expressions[c]}" for c in estimated if c in model.expressions]
    for entry in entries:
        name = entry["name"]
        if name in model.expressions:
            entry["expression"] = model.expressions[name]
        elif name in model.physical_names:
            entry["identify"] = name in ident.identifiable or name in ident.unidentifiable
            entry["identifiable"] = name in ident.identifiable
    if ident.identifiable:
        message = (
            f"{', '.join(ident.identifiable)} estimated from {', '.join(combos)} "
            "(standard errors by the delta method)"
        )
        from ..estimators._linear import _MSD_FORCE_EXPRESSIONS, _MSD_FORCE_NAMES

        if model.is_msd and model.expressions == _MSD_FORCE_EXPRESSIONS:
            message += "; physid estimate reports them as " + ", ".join(
                _MSD_FORCE_NAMES[p] for p in ident.identifiable if p in _MSD_FORCE_NAMES
            )
    elif ident.unidentifiable:
        message = (
            f"{', '.join(ident.unidentifiable)} are not identifiable: only the combinations "
            f"{', '.join(combos)} are estimated (the input carries no scale); measure the "
            'input in physical units (a force: b = ["1/m"]) or fix some of them '
            "(identify = false)"
        )
    else:
        message = ident.message
    return {
        "identifiable": list(ident.identifiable),
        "unidentifiable": list(ident.unidentifiable),
        "combinations": {c: model.expressions[c] for c in estimated if c in model.expressions},
        "message": message,
    }


def run_info(args) -> int:
    from ..models import load_model

    start = time.perf_counter()
    model = load_model(args.model)
    progress(f"physid model info: loaded {args.model!r} in {time.perf_counter() - start:.3f} s")
    info = describe(model, base=not args.no_base, force=args.base)
    if args.json:
        print_json(info)
        return 0
    lines = [f"model {info['name']} ({info['kind']})"]
    if "joints" in info:
        lines.append(f"joints ({len(info['joints'])}):")
        for j in info["joints"]:
            lim = j.get("limits")
            text = f"  {j['index']}. {j['name']} [{j['type']}]"
            if lim:
                lo, hi = lim["position"]
                text += (
                    f"  position {lo if lo is not None else '?'} .. {hi if hi is not None else '?'}"
                    f", velocity {lim['velocity'] if lim['velocity'] is not None else '?'}"
                    f", effort {lim['effort'] if lim['effort'] is not None else '?'}"
                )
            lines.append(text)
        lines.append(f"gravity {info['gravity']} m/s²; load {info['load_seconds']:.3f} s")
    lines.append(f"parameters ({len(info['parameters'])}):")
    for p in info["parameters"]:
        mark = "" if p["identify"] else "  (fixed)"
        if "expression" in p:
            mark = f"  = {p['expression']}" + ("  (estimated)" if p["identify"] else mark)
        elif p.get("identifiable") is not None and p["identify"]:
            mark = "  (estimated)" if p["identifiable"] else "  (not identifiable alone)"
        lines.append(f"  {p['name']} = {p['value']:.6g} {p['unit']}{mark}")
    if info.get("identifiability"):
        forces = [c for c in info["inputs"] if c not in info.get("bases", {}).values()]
        bases = "".join(f"; base {k} moved by {v!r}" for k, v in info.get("bases", {}).items())
        lines.append(f"nodes {info['nodes']}; forces {forces}{bases}; outputs {info['outputs']}")
        lines.append(f"identifiability: {info['identifiability']['message']}")
    if info.get("physical"):
        lines.append(f"physical parameters: {info['physical']['message']}")
    bp = info.get("base_parameters")
    if bp and "skipped" in bp:
        lines.append(f"base parameters: {bp['skipped']}")
    elif bp:
        lines.append(f"base parameters ({bp['n_base']} of {bp['n_columns']} columns):")
        for b in bp["base"]:
            lines.append(f"  {b['name']} = {b['expression']}")
            if b["words"]:
                lines.append(f"      {b['words']}")
        if bp["no_effect"]:
            lines.append(f"  no effect on the torques: {', '.join(bp['no_effect'])}")
        lines += [f"  {s}" for s in bp["unidentifiable"]]
    print("\n".join(lines))
    return 0
