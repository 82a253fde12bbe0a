"""Configuration files: bounded reading and parsing, a located error for every refusal."""
from __future__ import annotations

import pytest

from firenav_framework.cli import main
from firenav_framework.yaml_locations import MAX_BYTES, MAX_DEPTH, ConfigError, loads

LAUGHS = """\
a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]
b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]
c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]
d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]
e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]
f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]
g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]
h: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g]
i: &i [*h, *h, *h, *h, *h, *h, *h, *h, *h]
"""

MERGES = "a0: &a0 {k0: 1}\n" + "".join(
    f"a{i}: &a{i} {{<<: [*a{i - 1}, *a{i - 1}], k{i}: 1}}\n" for i in range(1, 40))


def validate(tmp_path, text: str, capsys) -> tuple[int, str]:
    path = tmp_path / "p.yaml"
    path.write_text(text)
    code = main(["validate", str(path)])
    return code, capsys.readouterr().err


@pytest.mark.timeout(30)
@pytest.mark.parametrize("text, line, message", [
    (LAUGHS, 6, "more than 200000 values once aliases are expanded"),      # f: 9^6 values
    (MERGES, None, "more than 200000 values once aliases are expanded"),   # 2^39 merged keys
    ("a: &a [1, *a]\n", 1, "an alias refers to the value it is part of"),
    ("x: " + "[" * 5000 + "]" * 5000 + "\n", 1, f"nested more than {MAX_DEPTH} levels deep"),
    ("".join(f"l{i}: &l{i} [*l{i - 1}]\n" if i else "l0: &l0 [1]\n" for i in range(200)),
     None, "levels deep once aliases are expanded"),
])
def test_alias_bombs_recursion_and_deep_nesting_are_refused_with_a_location(
        tmp_path, capsys, text, line, message):
    code, err = validate(tmp_path, text, capsys)
    assert code == 2, err
    assert message in err and "Traceback" not in err
    if line is not None:
        assert f"p.yaml:{line}:" in err


@pytest.mark.timeout(30)
def test_a_device_or_an_oversized_file_is_not_read_without_bound(tmp_path, capsys):
    assert main(["validate", "/dev/zero"]) == 2
    assert "/dev/zero: cannot read: not a regular file" in capsys.readouterr().err
    big = tmp_path / "big.yaml"
    big.write_bytes(b"# " + b"x" * (MAX_BYTES + 10) + b"\n")
    assert main(["validate", str(big)]) == 2
    assert f"larger than {MAX_BYTES} bytes" in capsys.readouterr().err


@pytest.mark.timeout(30)
def test_an_alias_bomb_in_a_set_value_is_refused(tmp_path, capsys):
    pipeline = tmp_path / "p.yaml"
    pipeline.write_text("sources: [{plugin: simulator, scenario: demo}]\n")
    bomb = LAUGHS.replace("\n", ", ").replace(": &", ": &").rstrip(", ")
    code = main(["validate", str(pipeline), "--set", "sources[0].x={" + bomb + "}"])
    assert code == 2
    assert "more than 200000 values" in capsys.readouterr().err


def test_ordinary_anchors_and_merge_keys_still_work():
    doc = loads("base: &b {x: 1, y: 2}\nitem: {<<: *b, z: 3}\nlist: [*b, *b]\n")
    assert doc.data["item"] == {"x": 1, "y": 2, "z": 3}
    assert doc.data["list"] == [{"x": 1, "y": 2}] * 2
    with pytest.raises(ConfigError):
        loads("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1))
    loads("[" * MAX_DEPTH + "]" * MAX_DEPTH)  # exactly at the limit is fine
