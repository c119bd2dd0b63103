"""The TOML tables of a structure model file (``kind = "structure"``): masses, springs, dampers,
forces and outputs between named nodes, or the matrices M, C, K written directly.

The format (docs/structures.md)::

    kind = "structure"
    name = "chain2"
    [parameters]
    m1 = { value = 2.0, unit = "kg" }
    [[masses]]
    name = "x1"
    mass = "m1"              # coulomb = "Fc1" adds Coulomb friction Fc1*sign(v) on the node
    [[springs]]
    between = ["ground", "x1"]
    stiffness = "k1"         # cubic = "k3" adds k3*d**3 (a Duffing spring), d the elongation
    [[dampers]]
    between = ["x1", "x2"]
    damping = "c2"
    [[forces]]
    on = "x1"
    channel = "F"
    [[base_motions]]         # a node moved by a measured displacement [m]; springs and
    name = "xb"              # dampers may join it like the ground (forces, bases or both)
    channel = "xb"
    [[outputs]]
    displacement = "x2"      # or velocity / acceleration (with anti_aliasing = "...")
    channel = "x2"

or, instead of masses/springs/dampers, ``[matrices]`` with ``nodes = ["x1", "x2"]`` and
``M``, ``C``, ``K`` as lists of rows of expressions. Only the structure is checked here; the
expressions are parsed (never evaluated as Python) when the model is built.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import ModelFileError, PhysidError
from ._locate import _where
from .spec_common import _expr_text, _parse_recording

__all__ = ["StructureSpec", "ElementSpec", "OutputSpec"]

_QUANTITIES = ("displacement", "velocity", "acceleration")
_TOP = {
    "name",
    "kind",
    "description",
    "parameters",
    "masses",
    "springs",
    "dampers",
    "forces",
    "base_motions",
    "outputs",
    "matrices",
    "recording",
}
GROUND = "ground"


@dataclass(frozen=True)
class ElementSpec:
    """One spring, damper or mass: the nodes it joins and its expressions.

    Attributes
    ----------
    kind : {"mass", "spring", "damper"}
        What the element is.
    nodes : tuple of str
        One node (a mass) or two (``"ground"`` allowed for springs and dampers).
    value : str
        Mass [kg], stiffness [N/m] or damping [N·s/m] as an expression of the parameters.
    extra : str
        A spring's cubic stiffness k3 [N/m³] or a mass's Coulomb force [N] ("" when none).
    where : str
        File, line and element, for messages.
    """

    kind: str
    nodes: tuple
    value: str
    extra: str = ""
    where: str = ""


@dataclass(frozen=True)
class OutputSpec:
    """A measured output: ``quantity`` of ``node`` in recording channel ``channel``.

    Attributes
    ----------
    quantity : {"displacement", "velocity", "acceleration"}
        What is measured [m, m/s, m/s²].
    node : str
        The node measured.
    channel : str
        The recording channel.
    anti_aliasing : str
        The note on the acquisition's anti-aliasing filter (acceleration outputs).
    where : str
        File, line and element, for messages.
    """

    quantity: str
    node: str
    channel: str
    anti_aliasing: str = ""
    where: str = ""


@dataclass(frozen=True)
class StructureSpec:
    """A lumped-parameter structure M q̈ + C q̇ + K q (+ cubic springs, friction) = B u.

    Attributes
    ----------
    name : str
        Model name.
    parameters : tuple of ParameterSpec
        In file order.
    nodes : tuple of str
        The coordinates q, in order.
    masses, springs, dampers : tuple of ElementSpec
        The elements (empty when ``matrices`` is given).
    matrices : tuple
        ``(("M", rows), ("C", rows), ("K", rows))`` of expression strings, or ().
    forces : tuple of (node, channel, where)
        Force inputs [N].
    bases : tuple of (node, channel, where)
        Base motions: nodes that move with a measured displacement [m] (not coordinates).
    outputs : tuple of OutputSpec
        Measured outputs.
    source : str
        The file.
    """

    name: str
    parameters: tuple
    nodes: tuple
    masses: tuple = ()
    springs: tuple = ()
    dampers: tuple = ()
    matrices: tuple = ()
    forces: tuple = ()
    outputs: tuple = ()
    bases: tuple = ()
    description: str = ""
    source: str = "<string>"
    recording: tuple = ()
    text: str = field(default="", repr=False, compare=False)

    @property
    def parameter_names(self) -> tuple:
        """Names of the parameters θ, in the order of the parameter vector."""
        return tuple(p.name for p in self.parameters)


def _table_list(data, key, source, example) -> list:
    value = data.get(key, [])
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise ModelFileError(f"{source}: [[{key}]] must be tables, e.g. {example}; got {value!r}.")
    return value


def _check_keys(entry, allowed, where, what) -> None:
    extra = set(entry) - set(allowed)
    if extra:
        raise ModelFileError(
            f"{where}: unknown key(s) {sorted(extra)} in {what}; allowed: {sorted(allowed)}."
        )


def _expression(value, where, names) -> str:
    """An expression entry, checked for syntax and declared names (parsed, never evaluated)."""
    text = _expr_text(value, where)
    from ..expressions import FUNCTION_NAMES, expression_names

    try:
        used, called = expression_names(text, source=where)
    except PhysidError as exc:
        raise ModelFileError(str(exc)) from None
    bad = [f for f in called if f not in FUNCTION_NAMES]
    if bad:
        raise ModelFileError(f"{where}: unknown function(s) {bad} in {text!r}.")
    unknown = [u for u in used if u not in names and u != "pi"]
    if unknown:
        raise ModelFileError(
            f"{where}: unknown symbol {unknown[0]!r} in {text!r}; declare it under [parameters] "
            f"({unknown[0]} = {{ value = ..., unit = ... }}). Known: {sorted(names)}."
        )
    return text


def _node(value, nodes, where, what, *, ground: bool, bases=()) -> str:
    allowed = [GROUND, *bases, *nodes] if ground else list(nodes)
    if not isinstance(value, str) or value not in allowed:
        if isinstance(value, str) and value in bases:
            raise ModelFileError(
                f"{where}: {what} {value!r} is a base (a [[base_motions]] entry, moved by its "
                f"measured channel), not a mass; {what} must be one of the [[masses]] names "
                f"{list(nodes)}."
            )
        raise ModelFileError(
            f"{where}: {what} {value!r} is not a node; the nodes are the [[masses]] names "
            f"{allowed}."
        )
    return value


def _parse_structure(data, text, source, name, params) -> StructureSpec:
    """The structure tables of a parsed TOML file as a `StructureSpec`."""
    extra = set(data) - _TOP
    if extra:
        where = _where(source, text, "top level", sorted(extra)[0])
        raise ModelFileError(
            f"{where}: unknown key(s) {sorted(extra)} for a structure model; allowed: "
            f"{sorted(_TOP)}."
        )
    names = {p.name for p in params}
    masses_given = [e.get("name") for e in data.get("masses", []) if isinstance(e, dict)]
    bases = _parse_bases(data, text, source, masses_given)
    base_names = tuple(b[0] for b in bases)
    if "matrices" in data:
        if bases:
            raise ModelFileError(
                f"{_where(source, text, 'matrices', 'matrices')}: [[base_motions]] need "
                "[[springs]]/[[dampers]] joining the base to the masses; [matrices] has no "
                "elements to join it to."
            )
        if any(k in data for k in ("masses", "springs", "dampers")):
            raise ModelFileError(
                f"{_where(source, text, 'matrices', 'matrices')}: give either [matrices] or "
                "[[masses]]/[[springs]]/[[dampers]], not both."
            )
        nodes, matrices = _parse_matrices(data["matrices"], text, source, names)
        masses = springs = dampers = ()
    else:
        matrices = ()
        masses = _parse_masses(data, text, source, names)
        nodes = tuple(m.nodes[0] for m in masses)
        springs = _parse_links(data, "springs", text, source, names, nodes, base_names)
        dampers = _parse_links(data, "dampers", text, source, names, nodes, base_names)
        _check_bases_joined(bases, springs, dampers)
    forces = _parse_forces(data, text, source, nodes, base_names, required=not bases)
    outputs = _parse_outputs(data, text, source, nodes, base_names)
    _check_base_accelerations(outputs, dampers, base_names)
    used = {}
    for channel, where in [(f[1], f[2]) for f in (*forces, *bases)] + [
        (o.channel, o.where) for o in outputs
    ]:
        if channel in used:
            raise ModelFileError(
                f"{where}: channel {channel!r} is already used at {used[channel]}; every force, "
                "base motion and output needs its own channel."
            )
        used[channel] = where
    spec = StructureSpec(
        name=name,
        parameters=params,
        nodes=nodes,
        masses=masses,
        springs=springs,
        dampers=dampers,
        matrices=matrices,
        forces=forces,
        outputs=outputs,
        bases=bases,
        description=str(data.get("description", "")),
        source=source,
        recording=tuple(_parse_recording(data, text, source).items()),
        text=text,
    )
    _check_reachable(spec)
    return spec


def _parse_masses(data, text, source, names) -> tuple:
    entries = _table_list(data, "masses", source, '[[masses]] name = "x1", mass = "m1"')
    if not entries:
        raise ModelFileError(
            f'{source}: a structure needs [[masses]] (name = "x1", mass = "m1") or [matrices].'
        )
    out, seen = [], set()
    for i, e in enumerate(entries):
        where = _where(source, text, f"masses[{i}]", "name", table="masses", index=i)
        _check_keys(e, {"name", "mass", "coulomb", "description"}, where, "[[masses]]")
        node = e.get("name")
        if not isinstance(node, str) or not node.strip() or node == GROUND or node in seen:
            raise ModelFileError(
                f"{where}: each mass needs a unique name other than 'ground' (its node, e.g. "
                f'name = "x1"); got {node!r}.'
            )
        seen.add(node)
        if "mass" not in e:
            raise ModelFileError(f'{where}: mass {node!r} has no mass; add mass = "m1".')
        value = _expression(e["mass"], f"{where}.mass", names)
        if value.strip() in ("0", "0.0"):
            raise ModelFileError(
                f"{where}: mass {node!r} is 0; every node needs a positive mass (a massless "
                "node makes M singular); merge it into a neighbour or give it a mass."
            )
        coulomb = _expression(e["coulomb"], f"{where}.coulomb", names) if "coulomb" in e else ""
        out.append(ElementSpec("mass", (node,), value, coulomb, where))
    return tuple(out)


def _parse_links(data, key, text, source, names, nodes, bases=()) -> tuple:
    value_key = "stiffness" if key == "springs" else "damping"
    allowed = {"between", value_key, "description"} | ({"cubic"} if key == "springs" else set())
    entries = _table_list(data, key, source, f'[[{key}]] between = ["ground", "x1"]')
    out = []
    for i, e in enumerate(entries):
        where = _where(source, text, f"{key}[{i}]", "between", table=key, index=i)
        _check_keys(e, allowed, where, f"[[{key}]]")
        between = e.get("between")
        if not isinstance(between, list) or len(between) != 2:
            raise ModelFileError(
                f'{where}: between must name two nodes, e.g. between = ["ground", "x1"]; got '
                f"{between!r}."
            )
        a, b = (_node(n, nodes, where, "node", ground=True, bases=bases) for n in between)
        fixed = {GROUND, *bases}
        if a in fixed and b in fixed:
            raise ModelFileError(
                f"{where}: {key[:-1]} between {a!r} and {b!r} joins no mass (both ends are "
                "the ground or a base); join a mass."
            )
        if "cubic" in e and (a in bases or b in bases):
            raise ModelFileError(
                f"{where}: a cubic spring on base {a if a in bases else b!r} is not supported; "
                "only linear springs and dampers may touch a base."
            )
        if a == b:
            raise ModelFileError(
                f"{where}: {key[:-1]} between {a!r} and itself does nothing; join two different "
                "nodes."
            )
        if value_key not in e and "cubic" not in e:
            raise ModelFileError(f'{where}: add {value_key} = "..." to the {key[:-1]}.')
        val = _expression(e.get(value_key, 0), f"{where}.{value_key}", names)
        cubic = _expression(e["cubic"], f"{where}.cubic", names) if "cubic" in e else ""
        out.append(ElementSpec(key[:-1], (a, b), val, cubic, where))
    return tuple(out)


def _parse_matrices(table, text, source, names) -> tuple:
    where = _where(source, text, "matrices", "nodes", table="matrices")
    if not isinstance(table, dict):
        raise ModelFileError(f"{where}: [matrices] must be a table with nodes, M, C and K.")
    _check_keys(table, {"nodes", "M", "C", "K"}, where, "[matrices]")
    nodes = table.get("nodes")
    if (
        not isinstance(nodes, list)
        or not nodes
        or not all(isinstance(n, str) and n.strip() and n != GROUND for n in nodes)
        or len(set(nodes)) != len(nodes)
    ):
        raise ModelFileError(
            f'{where}: nodes must list the coordinates, e.g. nodes = ["x1", "x2"]; got {nodes!r}.'
        )
    n = len(nodes)
    out = []
    for key in ("M", "C", "K"):
        rows = table.get(key, [["0"] * n for _ in range(n)] if key == "C" else None)
        kwhere = _where(source, text, f"matrices.{key}", key, table="matrices")
        if (
            not isinstance(rows, list)
            or len(rows) != n
            or any(not isinstance(r, list) or len(r) != n for r in rows)
        ):
            raise ModelFileError(
                f"{kwhere}: {key} must be {n}×{n} (one row per node {nodes}), as lists of "
                f"expressions; got {rows!r}."
            )
        parsed = tuple(
            tuple(_expression(v, f"{kwhere}[{i}][{j}]", names) for j, v in enumerate(r))
            for i, r in enumerate(rows)
        )
        out.append((key, parsed))
    return tuple(nodes), tuple(out)


def _parse_forces(data, text, source, nodes, bases=(), *, required: bool = True) -> tuple:
    entries = _table_list(data, "forces", source, '[[forces]] on = "x1", channel = "F"')
    if not entries and required:
        raise ModelFileError(
            f'{source}: a structure needs [[forces]] (on = "x1", channel = "F") or '
            '[[base_motions]] (name = "xb", channel = "xb").'
        )
    out, channels = [], set()
    for i, e in enumerate(entries):
        where = _where(source, text, f"forces[{i}]", "on", table="forces", index=i)
        _check_keys(e, {"on", "channel", "description"}, where, "[[forces]]")
        node = _node(e.get("on"), nodes, where, "on", ground=False, bases=bases)
        channel = e.get("channel", f"F_{node}")
        if not isinstance(channel, str) or not channel.strip() or channel in channels:
            raise ModelFileError(f"{where}: channel must be a unique name; got {channel!r}.")
        channels.add(channel)
        out.append((node, channel, where))
    return tuple(out)


def _parse_bases(data, text, source, masses) -> tuple:
    """[[base_motions]]: (name, channel, where) of each base, a node moved by a measured
    displacement [m] that springs and dampers may join, like the ground."""
    entries = _table_list(data, "base_motions", source, '[[base_motions]] name = "xb"')
    out, seen = [], set()
    for i, e in enumerate(entries):
        where = _where(source, text, f"base_motions[{i}]", "name", table="base_motions", index=i)
        _check_keys(e, {"name", "channel", "description"}, where, "[[base_motions]]")
        node = e.get("name")
        if not isinstance(node, str) or not node.strip() or node == GROUND or node in seen:
            raise ModelFileError(
                f"{where}: each base needs a unique name other than 'ground' (the node springs "
                f'and dampers join, e.g. name = "xb"); got {node!r}.'
            )
        if node in masses:
            raise ModelFileError(
                f"{where}: base {node!r} has the name of a mass; a base is moved by its "
                "measured displacement, a mass by the forces on it: give the base another name."
            )
        seen.add(node)
        channel = e.get("channel", node)
        if not isinstance(channel, str) or not channel.strip():
            raise ModelFileError(
                f"{where}: channel must name the recording channel of the base's measured "
                f"displacement [m]; got {channel!r}."
            )
        out.append((node, channel, where))
    return tuple(out)


def _check_base_accelerations(outputs, dampers, bases) -> None:
    for o in outputs:
        hit = [d for d in dampers if o.node in d.nodes and set(d.nodes) & set(bases)]
        if o.quantity == "acceleration" and hit:
            raise ModelFileError(
                f"{o.where}: the acceleration of {o.node!r}, joined to a base by the damper at "
                f"{hit[0].where}, follows the base's velocity without lag (its transfer "
                "function from x_b is improper); measure its displacement or velocity instead."
            )


def _check_bases_joined(bases, springs, dampers) -> None:
    touched = {n for e in (*springs, *dampers) for n in e.nodes}
    for node, _, where in bases:
        if node not in touched:
            raise ModelFileError(
                f"{where}: base {node!r} is joined to no mass: no [[springs]] or [[dampers]] "
                f'has it in between (e.g. between = ["{node}", "x1"]); it moves nothing.'
            )


def _parse_outputs(data, text, source, nodes, bases=()) -> tuple:
    entries = _table_list(data, "outputs", source, '[[outputs]] displacement = "x2"')
    if not entries:
        raise ModelFileError(f'{source}: a structure needs [[outputs]] (displacement = "x2").')
    out, channels = [], set()
    for i, e in enumerate(entries):
        key = next((q for q in _QUANTITIES if q in e), None)
        where = _where(source, text, f"outputs[{i}]", key or "channel", table="outputs", index=i)
        _check_keys(e, {*_QUANTITIES, "channel", "anti_aliasing", "description"}, where, "output")
        given = [q for q in _QUANTITIES if q in e]
        if len(given) != 1:
            raise ModelFileError(
                f"{where}: an output measures exactly one of {list(_QUANTITIES)} of a node; "
                f"got {given}."
            )
        node = _node(e[key], nodes, where, key, ground=False, bases=bases)
        channel = e.get("channel", node if key == "displacement" else f"{key[0]}_{node}")
        if not isinstance(channel, str) or not channel.strip() or channel in channels:
            raise ModelFileError(f"{where}: channel must be a unique name; got {channel!r}.")
        channels.add(channel)
        note = e.get("anti_aliasing", "")
        if key == "acceleration" and (not isinstance(note, str) or not note.strip()):
            raise ModelFileError(
                f"{where}: an acceleration output needs an anti_aliasing note (the analog "
                'low-pass before sampling, e.g. anti_aliasing = "4-pole Butterworth at 200 Hz"): '
                "an accelerometer sees the high-frequency modes that a displacement sensor does "
                "not, and without a filter they fold into the band the model is fitted in."
            )
        out.append(OutputSpec(key, node, channel, str(note), where))
    return tuple(out)


def _check_reachable(spec: StructureSpec) -> None:
    """Each output node must be connected to a forced node through springs, dampers or a
    non-zero matrix entry (else no input reaches it)."""
    adjacency = {n: set() for n in (*spec.nodes, *(b[0] for b in spec.bases))}
    for e in (*spec.springs, *spec.dampers):
        a, b = e.nodes
        if GROUND not in (a, b):
            adjacency[a].add(b)
            adjacency[b].add(a)
    for _, rows in spec.matrices:
        for i, r in enumerate(rows):
            for j, v in enumerate(r):
                if i != j and v.strip() not in ("0", "0.0"):
                    adjacency[spec.nodes[i]].add(spec.nodes[j])
                    adjacency[spec.nodes[j]].add(spec.nodes[i])
    reached = {f[0] for f in spec.forces} | {b[0] for b in spec.bases}
    frontier = list(reached)
    while frontier:
        for m in adjacency[frontier.pop()] - reached:
            reached.add(m)
            frontier.append(m)
    for o in spec.outputs:
        if o.node not in reached:
            raise ModelFileError(
                f"{o.where}: no input reaches node {o.node!r} (it is joined to no forced node "
                f"or base {sorted({f[0] for f in (*spec.forces, *spec.bases)})} by springs or "
                "dampers); its output "
                "carries no information. Join it, force it, or drop the output."
            )
