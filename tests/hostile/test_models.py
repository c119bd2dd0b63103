"""Hostile model files (URDF, sidecars, rigid-body and point-mass TOML chains) through the CLI.

Each case writes its files into a temporary folder and runs ``physid model info`` (or
``simulate``) in-process: exit status 2 and one ``physid: error:`` message that names the file
or element and the fix. Table format as tests/hostile (case_id, files, argv, exit, regex).
"""

import pytest

import physid
from physid.errors import ModelFileError
from physid.models.urdf import ModelWarning

from ._cases import check_case


def urdf(body: str, name: str = "r") -> str:
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}\n</robot>\n'


def link(name, mass=1.0, inertia="0.01 0 0 0.01 0 0.01", origin="0.1 0 0"):
    ixx, ixy, ixz, iyy, iyz, izz = inertia.split()
    return (
        f'<link name="{name}"><inertial><origin xyz="{origin}"/><mass value="{mass}"/>'
        f'<inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" iyz="{iyz}" izz="{izz}"/>'
        "</inertial></link>"
    )


def joint(name, parent, child, kind="revolute", axis="0 0 1", extra=""):
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="0 0 0.1"/><axis xyz="{axis}"/>{extra}</joint>'
    )


GOOD = urdf('<link name="base"/>' + link("l1") + joint("j1", "base", "l1"))

TOML_RIGID = """
name = "bad"
{top}
[[joints]]
{joint}
"""

CASES = [
    ("urdf-not-xml", {"r.urdf": "<robot><link name='a'>"}, r"r\.urdf: not a well-formed XML"),
    ("urdf-binary", {"r.urdf": b"\xff\xfe\x00garbage"}, r"not a UTF-8 text file|not a well-formed"),
    ("urdf-empty", {"r.urdf": ""}, r"r\.urdf: the URDF file is empty"),
    ("urdf-not-robot", {"r.urdf": "<model/>"}, r"root element is <model>, not <robot>"),
    (
        "urdf-entity",
        {
            "r.urdf": '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaa">]><robot name="x">'
            "<link name='a'/></robot>"
        },
        r"declares an entity",
    ),
    (
        "urdf-missing-parent",
        {"r.urdf": urdf('<link name="base"/>' + link("l1") + joint("j1", "nobody", "l1"))},
        r"line \d+ \(joint 'j1'\): parent link 'nobody' is not defined",
    ),
    (
        "urdf-missing-child",
        {"r.urdf": urdf('<link name="base"/>' + joint("j1", "base", "ghost"))},
        r"child link 'ghost' is not defined",
    ),
    (
        "urdf-loop",
        {
            "r.urdf": urdf(
                '<link name="base"/>'
                + link("l1")
                + link("l2")
                + joint("j1", "base", "l1")
                + joint("j2", "l1", "l2")
                + joint("j3", "base", "l2")
            )
        },
        r"link 'l2' is the child of two joints .*loop",
    ),
    (
        "urdf-cycle-no-root",
        {"r.urdf": urdf(link("a") + link("b") + joint("j1", "a", "b") + joint("j2", "b", "a"))},
        r"loop",
    ),
    (
        "urdf-two-roots",
        {
            "r.urdf": urdf(
                '<link name="base"/><link name="other"/>' + link("l1") + joint("j", "base", "l1")
            )
        },
        r"2 root links \['base', 'other'\]",
    ),
    (
        "urdf-negative-mass",
        {"r.urdf": urdf('<link name="base"/>' + link("l1", mass=-2) + joint("j1", "base", "l1"))},
        r"link 'l1' inertial\): mass -2.0 kg is negative",
    ),
    (
        "urdf-zero-axis",
        {
            "r.urdf": urdf(
                '<link name="base"/>' + link("l1") + joint("j1", "base", "l1", axis="0 0 0")
            )
        },
        r"the axis of joint 'j1' has zero length",
    ),
    (
        "urdf-bad-axis-text",
        {
            "r.urdf": urdf(
                '<link name="base"/>' + link("l1") + joint("j1", "base", "l1", axis="0 z 1")
            )
        },
        r"axis xyz='0 z 1' must be 3 numbers",
    ),
    (
        "urdf-planar",
        {"r.urdf": urdf('<link name="base"/>' + link("l1") + joint("j1", "base", "l1", "planar"))},
        r"joint type 'planar' is not supported",
    ),
    (
        "urdf-floating",
        {
            "r.urdf": urdf(
                '<link name="base"/>' + link("l1") + joint("j1", "base", "l1", "floating")
            )
        },
        r"joint type 'floating' is not supported",
    ),
    (
        "urdf-unknown-type",
        {"r.urdf": urdf('<link name="base"/>' + link("l1") + joint("j1", "base", "l1", "hinge"))},
        r"unknown joint type 'hinge'",
    ),
    (
        "urdf-mimic",
        {
            "r.urdf": urdf(
                '<link name="base"/>'
                + link("l1")
                + link("l2")
                + joint("j1", "base", "l1")
                + joint("j2", "l1", "l2", extra='<mimic joint="j9"/>')
            )
        },
        r"joint 'j2' mimics 'j9', which is not a joint of the robot",
    ),
    (
        "urdf-nothing-moves",
        {"r.urdf": urdf('<link name="base"/>' + link("l1") + joint("j1", "base", "l1", "fixed"))},
        r"no revolute, continuous or prismatic joint",
    ),
    (
        "urdf-not-finite",
        {
            "r.urdf": urdf(
                '<link name="base"/>' + link("l1", mass="nan") + joint("j1", "base", "l1")
            )
        },
        r"value='nan' must be finite",
    ),
    (
        "sidecar-missing-urdf",
        {"s.toml": 'extends = "nothing.urdf"\n'},
        r"extends = 'nothing.urdf': no such file",
    ),
    (
        "sidecar-unknown-joint",
        {"r.urdf": GOOD, "s.toml": 'extends = "r.urdf"\n[joints.elbow]\narmature = 0.1\n'},
        r"the URDF has no movable joint 'elbow'; its joints: \['j1'\]",
    ),
    (
        "sidecar-unknown-key",
        {"r.urdf": GOOD, "s.toml": 'extends = "r.urdf"\n[joints.j1]\narmatur = 0.1\n'},
        r"unknown key\(s\) \['armatur'\]",
    ),
    (
        "sidecar-strict-triangle",
        {
            "r.urdf": urdf(
                '<link name="base"/>'
                + link("l1", inertia="0.01 0 0 0.01 0 0.5")
                + joint("j1", "base", "l1")
            ),
            "s.toml": 'extends = "r.urdf"\nstrict = true\n',
        },
        r"violate the triangle inequality",
    ),
    (
        "sidecar-strict-not-pd",
        {
            "r.urdf": urdf(
                '<link name="base"/>'
                + link("l1", inertia="0.01 0 0 -0.01 0 0.01")
                + joint("j1", "base", "l1")
            ),
            "s.toml": 'extends = "r.urdf"\nstrict = true\n',
        },
        r"not positive semi-definite",
    ),
    (
        "sidecar-identify-unknown",
        {"r.urdf": GOOD, "s.toml": 'extends = "r.urdf"\nidentify = ["m7"]\n'},
        r"identify names unknown parameter\(s\) \['m7'\]",
    ),
    (
        "toml-prismatic-paper-kinetic",
        {
            "m.toml": TOML_RIGID.format(
                top='kinetic_energy = "paper"',
                joint='type = "prismatic"\ndh = { d = 0.1 }\nmass = 1.0',
            )
        },
        r"kinetic_energy = 'paper'.* cannot be used with a prismatic joint",
    ),
    (
        "toml-planar-type",
        {
            "m.toml": TOML_RIGID.format(
                top="", joint='type = "planar"\ndh = { a = 0.1 }\nmass = 1.0'
            )
        },
        r"joint type 'planar' is not supported",
    ),
    (
        "toml-physical-and-standard",
        {
            "m.toml": TOML_RIGID.format(
                top="", joint='type = "revolute"\ndh = { a = 0.1 }\nmass = 1.0\nXX = 0.1'
            )
        },
        r"either physically \(mass, com, inertia\) or by its standard parameters",
    ),
    (
        "toml-negative-standard-mass",
        {
            "m.toml": TOML_RIGID.format(
                top="", joint='type = "revolute"\ndh = { a = 0.1 }\nm = -1.0\nmcx = -0.1'
            )
        },
        r"m = -1.0 kg is negative",
    ),
    (
        "toml-zero-axis",
        {
            "m.toml": TOML_RIGID.format(
                top="",
                joint="transform = [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\naxis = [0, 0, 0]\n"
                "mass = 1.0\ncom = [0.1, 0, 0]",
            )
        },
        r"axis has zero length",
    ),
    (
        "toml-transform-with-q",
        {
            "m.toml": TOML_RIGID.format(
                top="",
                joint='type = "revolute"\ntransform = [["cos(q1)","-sin(q1)",0,0],["sin(q1)",'
                '"cos(q1)",0,0],[0,0,1,0],[0,0,0,1]]\nmass = 1.0\ncom = [0.1, 0, 0]',
            )
        },
        r"the transform is the constant placement of the joint frame \(no q1\)",
    ),
    (
        "toml-point-mass-singular",
        {"m.toml": 'name = "p"\n[parameters]\nm1 = 2.0\n[[joints]]\ndh = { a = 0 }\nmass = "m1"\n'},
        r"mass matrix is singular .*zero-length link",
    ),
    (
        "toml-strict-negative-mass",
        {
            "m.toml": 'name = "p"\nstrict = true\n[parameters]\nm1 = 2.0\n[[joints]]\n'
            'type = "revolute"\ndh = { a = 0.3 }\nmass = "-m1"\n'
        },
        r"the mass.* -2.0 kg is negative|mass -2.0 kg is negative",
    ),
]


@pytest.mark.parametrize(("case_id", "files", "regex"), CASES, ids=[c[0] for c in CASES])
def test_hostile_model_files(case_id, files, regex, hostile):
    """Through the shared framework: exit 2, one error line, the regex, no escaped warning."""
    for name, content in files.items():
        mode = "wb" if isinstance(content, bytes) else "w"
        with open(hostile.tmp / name, mode) as fh:
            fh.write(content)
    target = next(iter(reversed(files)))
    check_case(hostile, ["model", "info", f"{{tmp}}/{target}", "--no-base"], 2, regex)


def test_doubtful_inertia_warns_and_strict_refuses(tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text(
        urdf(
            '<link name="base"/>'
            + link("l1", inertia="0.01 0 0 0.01 0 0.5")
            + joint("j", "base", "l1")
        )
    )
    with pytest.warns(ModelWarning, match="triangle inequality"):
        physid.load_model(path)
    with pytest.raises(ModelFileError, match="triangle inequality"):
        physid.load_model(path, strict=True)


def test_negative_point_mass_warns_in_a_symbolic_chain(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(
        'name = "neg"\n[parameters]\nm1 = -2.0\nl1 = 0.5\n[[joints]]\ndh = { a = "l1" }\n'
        'mass = "m1"\n'
    )
    with pytest.warns(ModelWarning, match="mass .* is -2 at the nominal parameter values"):
        physid.load_model(path, cache=False)
    with pytest.raises(ModelFileError, match="must be >= 0"):
        physid.load_model(path, strict=True, cache=False)


def test_slow_derivations_say_so_on_stderr(capsys):
    import time

    from physid.models.chain import _with_progress
    from physid.models.library import manipulator_spec

    spec = manipulator_spec()
    assert _with_progress(spec, lambda: 7, after=5.0) == 7
    assert capsys.readouterr().err == ""  # quick: nothing printed
    assert _with_progress(spec, lambda: time.sleep(0.3) or 8, after=0.05) == 8
    err = capsys.readouterr().err
    assert "deriving the equations of motion of 'manipulator' (4 joints" in err
    assert "derived the equations of motion of 'manipulator' in" in err


SINGULAR = [
    (
        "urdf-massless",
        {"r.urdf": urdf('<link name="base"/><link name="l1"/>' + joint("j1", "base", "l1"))},
        r"mass matrix is singular .*joint 1 \('j1'\) moves no mass",
    ),
    (
        "toml-zero-length-link",
        {
            "m.toml": TOML_RIGID.format(
                top="", joint='type = "revolute"\ndh = { a = 0.0, d = 0.2 }\nmass = 2.0'
            )
        },
        r"mass matrix is singular .*moves no mass or inertia \(a zero-length link",
    ),
]


@pytest.mark.parametrize(("case_id", "files", "regex"), SINGULAR, ids=[c[0] for c in SINGULAR])
def test_singular_mass_matrix_loads_and_simulation_refuses(case_id, files, regex, hostile):
    """A link without inertia: the model loads with a note (identification needs Y, not M⁻¹);
    simulating it is an error that gives the reason."""
    for name, content in files.items():
        (hostile.tmp / name).write_text(content)
    target = f"{{tmp}}/{next(iter(files))}"
    res = check_case(hostile, ["model", "info", target, "--no-base"], 0, regex)
    assert "physid: warning:" in res.err and "loads for identification" in res.err
    check_case(
        hostile,
        ["simulate", "model", target, "--out", "{tmp}/sim.csv"],
        2,
        r"cannot simulate: .*mass matrix is singular.*needs an invertible M\(q\)",
    )
