"""Messages that name the right cause (hostile input): the scheduler's accepted forms, a
string where a model file needs a boolean, a sidecar that extends itself, a start value out of
scale, coefficients that are not finite, a model order the algebraic estimator cannot take, a
model whose base parameters cannot or should not be computed.

Each case: ``(case_id, argv, expected_exit, message_regex)`` as in ``tests/hostile/_cases.py``;
``{NAME}`` placeholders beyond the shared ones are the files written by `_files`.
"""

from __future__ import annotations

import pytest

from ._cases import case_ids, check_case

_ODE = (
    'name = "ode"\nkind = "linear_ode"\n[parameters]\n'
    "theta1 = {{ value = 1.0, identify = true }}\ntheta2 = {{ value = 1.0, identify = true }}\n"
    'b0 = {{ value = 1.0 }}\n[ode]\na = {a}\nb = ["b0"]\ninput = "u"\noutput = "x"\n'
)


def _chain_urdf(n: int) -> str:
    """A serial chain of ``n`` revolute joints with alternating axes."""
    parts = ['<robot name="long">', '<link name="l0"/>']
    for i in range(1, n + 1):
        axis = "0 0 1" if i % 2 else "0 1 0"
        parts.append(
            f'<link name="l{i}"><inertial><origin xyz="0.05 0 0"/><mass value="1"/>'
            '<inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>'
            f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
            f'<origin xyz="0.1 0 0"/><axis xyz="{axis}"/>'
            '<limit lower="-3" upper="3" velocity="2" effort="100"/></joint>'
        )
    return "\n".join([*parts, "</robot>"])


def _files(tmp):
    from pathlib import Path

    urdf = Path("tests/data/planar2.urdf").resolve()
    files = {
        "strict_toml": f'extends = "{urdf}"\nstrict = "false"\n',
        "self_toml": 'extends = "self.toml"\n',
        "ring_a_toml": 'extends = "ring_b.toml"\n',
        "ring_b_toml": 'extends = "ring_a.toml"\n',
        "abs_toml": (
            'name = "pa"\ngravity = [0, -9.81, 0]\n[parameters]\n'
            'm1 = { value = 2.0, unit = "kg" }\nl1 = { value = 0.5, unit = "m" }\n'
            '[[joints]]\ndh = { a = "Abs(l1)" }\nmass = "m1"\n'
        ),
        "div0_toml": _ODE.format(a='["theta2", "theta1/(theta2 - 1)"]'),
        "huge_toml": _ODE.format(a='["theta2", 1e400]'),
        "order30_toml": _ODE.format(a="[" + ", ".join(['"theta2"', *["1.0"] * 29]) + "]"),
        "long_urdf": _chain_urdf(200),
    }
    out = {}
    for name, text in files.items():
        stem, ext = name.rsplit("_", 1)
        path = tmp / f"{stem}.{ext}"
        path.write_text(text, encoding="utf-8")
        out[name] = path
    return out


CASES = [
    (
        "scheduler-file-url",
        [
            "sweep",
            "msd",
            "--snr",
            "25",
            "--ratio",
            "1",
            "--trials",
            "1",
            "--scheduler",
            "file:///etc/passwd",
            "--out",
            "{tmp}/sw",
        ],
        2,
        r"--scheduler 'file:///etc/passwd'.*tcp://.*'local:N'",
    ),
    (
        "scheduler-http-url",
        [
            "sweep",
            "msd",
            "--snr",
            "25",
            "--ratio",
            "1",
            "--trials",
            "1",
            "--scheduler",
            "http://example.invalid:80",
            "--out",
            "{tmp}/sw",
        ],
        2,
        r"--scheduler .*Dask schemes",
    ),
    ("strict-string", ["model", "info", "{strict_toml}"], 2, r"line 2 \(strict\).*TOML boolean"),
    (
        "sidecar-self",
        ["model", "info", "{self_toml}"],
        2,
        r"extends = 'self.toml' names the sidecar itself",
    ),
    ("sidecar-ring", ["model", "info", "{ring_a_toml}"], 2, r"names another sidecar TOML"),
    (
        "abs-model-info",
        ["model", "info", "{abs_toml}"],
        0,
        r"base parameters: not available: model 'pa' is not polynomial",
    ),
    ("ode-div0", ["model", "info", "{div0_toml}"], 2, r"line 8 \(ode.a\): coefficient .* is inf"),
    (
        "ode-huge-number",
        ["model", "info", "{huge_toml}"],
        2,
        r"line 8 \(ode.a\): entry 1 .* is inf",
    ),
    (
        "ode-order-30-no-mu",
        ["estimate", "{msd_csv}", "--model", "{order30_toml}"],
        2,
        r"cannot handle a model of order 30.*--method rls",
    ),
    (
        "initial-1e308",
        ["identify", "{arm_csv}", "--model", "manipulator", "--initial", "m1=1e308"],
        2,
        r"m1 = 1e\+308 .*out of scale.*--initial NAME=VALUE",
    ),
    (
        "model-info-200-joints",
        ["model", "info", "{long_urdf}"],
        0,
        r"base parameters .*skipped: 2000 regressor columns.*--base",
    ),
]


@pytest.mark.parametrize(
    ("case_id", "argv", "expected_exit", "message_regex"), CASES, ids=case_ids(CASES)
)
def test_messages(case_id, argv, expected_exit, message_regex, hostile):
    for name, path in _files(hostile.tmp).items():
        hostile.add_file(name, path)
    check_case(hostile, argv, expected_exit, message_regex)
