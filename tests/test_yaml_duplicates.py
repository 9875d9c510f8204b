"""Every YAML reader rejects a key given twice, naming the file, the key path and both lines
(PyYAML alone keeps the last value silently)."""

from __future__ import annotations

from importlib import resources

import pytest

from uuvid.simulate.scenario import load_scenario
from uuvid.thruster.modelfile import ModelFileError, load_chain, load_yaml_unique
from uuvid.vehicle.definition import load_vehicle


def test_nested_duplicate_gives_the_key_path_and_both_lines():
    with pytest.raises(ModelFileError) as exc:
        load_yaml_unique("a: 1\nb:\n  - {c: 1}\n  - c: 2\n    d: 3\n    c: 4\n", "f.yaml")
    msg = str(exc.value)
    assert msg.startswith("f.yaml: duplicated key b[1].c (lines 4 and 6)")


def test_unique_keys_aliases_and_merge_keys_still_load():
    doc = load_yaml_unique("a: &x {b: 1}\nc: *x\nm: {<<: *x, f: 2}\n", "f.yaml")
    assert doc == {"a": {"b": 1}, "c": {"b": 1}, "m": {"b": 1, "f": 2}}


def test_model_file(tmp_path):
    p = tmp_path / "m.yaml"
    p.write_text("name: x\ninput: command\nblocks:\n  - type: quadratic\n    k_pos: 1.0\n"
                 "    k_neg: 2.0\n    k_pos: 3.0\n")
    with pytest.raises(ModelFileError, match=r"m.yaml: duplicated key blocks\[0\].k_pos "
                                             r"\(lines 5 and 7\)"):
        load_chain(p)


def test_vehicle_file(tmp_path):
    text = resources.files("uuvid.vehicle").joinpath("presets/bluerov2.yaml").read_text()
    line = "  mass: 11.5                      # kg\n"
    assert line in text
    p = tmp_path / "rov.yaml"
    p.write_text(text.replace(line, line + "  mass: 115\n"))
    with pytest.raises(ModelFileError, match=r"rov.yaml: duplicated key rigid_body.mass"):
        load_vehicle(p)


def test_scenario_file(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text("vehicle: bluerov2\nmission:\n  kind: square\n  depth: 2.0\n  depth: 20.0\n")
    with pytest.raises(ModelFileError, match=r"s.yaml: duplicated key mission.depth"):
        load_scenario(p)


@pytest.mark.slow
def test_deep_nesting_is_an_error_or_a_document_never_a_recursion_error():
    text = "a: " + "[" * 5000 + "]" * 5000 + "\n"
    try:
        load_yaml_unique(text, "deep.yaml")
    except ModelFileError:
        pass


def test_a_tab_in_the_indentation_is_named(tmp_path):
    """PyYAML says "found character that cannot start any token" for a tab; the error says it is
    a tab and that YAML indents with spaces; other syntax errors get no such hint."""
    from uuvid.thruster.modelfile import ModelFileError, read_model_text

    p = tmp_path / "tab.yaml"
    p.write_text("name: x\nrigid_body:\n\tmass: 3\n")
    with pytest.raises(ModelFileError, match="line 3 is indented with a tab: YAML indents with spaces"):
        read_model_text(p)
    p.write_text("name: [x\nrigid_body:\n  mass: 3\n")
    with pytest.raises(ModelFileError) as e:
        read_model_text(p)
    assert "indented with a tab" not in str(e.value)
