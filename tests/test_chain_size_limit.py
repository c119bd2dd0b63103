"""A symbolic chain model beyond `MAX_SYMBOLIC_JOINTS` joints is refused at once, naming the limit
and why; a 200-joint model file is read (and its errors located) without a quadratic scan."""

from __future__ import annotations

import pytest

import physid
from physid.cli import main
from physid.errors import ModelFileError
from physid.models.chain import MAX_SYMBOLIC_JOINTS


def _chain(n: int, extra: dict[int, str] | None = None) -> str:
    lines = [f'name = "c{n}"', 'kind = "chain"', "gravity = [0.0, 0.0, -9.81]", "[parameters]"]
    for j in range(1, n + 1):
        lines.append(f'm{j} = {{ value = 1.0, unit = "kg", identify = true }}')
        lines.append(f'l{j} = {{ value = 0.3, unit = "m" }}')
    for j in range(1, n + 1):
        lines += ["", "[[joints]]", f'name = "j{j}"', f'dh = {{ a = "l{j}" }}', f'mass = "m{j}"']
        if extra and j in extra:
            lines.append(extra[j])
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("n", [MAX_SYMBOLIC_JOINTS + 1, 200])
def test_long_symbolic_chain_is_refused_with_the_limit(tmp_path, n):
    path = tmp_path / f"c{n}.toml"
    path.write_text(_chain(n))
    with pytest.raises(ModelFileError, match=rf"has {n} joints; .*limited to 6 joints.*URDF"):
        physid.load_model(path, cache=False)


def test_long_symbolic_chain_refused_on_the_command_line(tmp_path, capsys):
    path = tmp_path / "c200.toml"
    path.write_text(_chain(200))
    assert main(["model", "info", str(path)]) == 2
    err = capsys.readouterr().err
    assert "200 joints" in err and "limited to 6 joints" in err
    assert "grows like a high power of the joint count" in err
    assert "Traceback" not in err


def test_error_in_a_long_file_names_its_line(tmp_path):
    text = _chain(200, {150: "masss = 1"})
    path = tmp_path / "typo.toml"
    path.write_text(text)
    line = text.splitlines().index("masss = 1") + 1
    with pytest.raises(ModelFileError, match=rf"line {line}\b"):
        physid.load_model(path, cache=False)


def test_the_limit_itself_is_accepted_by_the_check():
    from physid.models.chain import _check_symbolic_size
    from physid.models.spec import parse_model_text

    _check_symbolic_size(parse_model_text(_chain(MAX_SYMBOLIC_JOINTS)))  # no error
    with pytest.raises(ModelFileError, match="has 7 joints"):
        _check_symbolic_size(parse_model_text(_chain(MAX_SYMBOLIC_JOINTS + 1)))
