"""YAML with positions: what a behaviour file may not contain, and where each problem is."""
from __future__ import annotations

from pathlib import Path

import pytest

from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.source import MAX_BYTES, load, loads

HEAD = "labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"


def problems(text: str) -> list[tuple[int, int, str]]:
    with pytest.raises(LabsimError) as e:
        loads(text, "b.yaml")
    return [(d.line, d.col, d.message) for d in e.value.diagnostics]


def compile_problems(path: Path) -> list[tuple[int, int, str, tuple[str, ...]]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    return [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]


def test_tab_indentation() -> None:
    assert problems("rules:\n\t- always stop()\n") == [(2, 1, "tab character: YAML indentation must use spaces")]


def test_yaml_syntax_error_names_the_unclosed_bracket() -> None:
    with pytest.raises(LabsimError) as e:
        loads("robots: {p: {model: x}\nrules: []\n", "b.yaml")
    (d,) = e.value.diagnostics
    assert (d.line, d.col) == (2, 1)
    assert d.message.startswith("YAML syntax error: expected ',' or '}'")
    assert d.notes == ("hint: the '{' on line 1, column 9 is never closed",)


def test_file_ending_inside_a_bracket_points_at_it() -> None:
    ((line, col, message),) = problems("rules: [a, b\n")
    assert (line, col) == (1, 8)
    assert "the end of the file" in message
    with pytest.raises(LabsimError) as e:
        loads("rules: [a, b\n", "b.yaml")
    assert e.value.diagnostics[0].notes == ("hint: this '[' is never closed: close it with ']'",)


def test_aliases_and_anchors_are_refused() -> None:
    assert problems("a: &x 1\nb: *x\n") == [
        (1, 4, "YAML anchors (&x) are not supported in labsim files: write the value out")]


def test_python_tags_are_refused_without_running_anything() -> None:
    assert problems("a: !!python/object/apply:os.system ['echo hi']\n") == [
        (1, 4, "YAML tag '!!python/object/apply:os.system' is not allowed: labsim files hold plain data")]


def test_duplicate_keys() -> None:
    assert problems("rules: []\nname: a\nrules: []\n") == [
        (3, 1, "duplicate key 'rules' (first given on line 1)")]


def test_file_over_the_size_cap(tmp_path: Path) -> None:
    p = tmp_path / "big.yaml"
    p.write_text("# " + "x" * MAX_BYTES + "\n")
    with pytest.raises(LabsimError) as e:
        load(p)
    (d,) = e.value.diagnostics
    assert d.message.startswith("file is 1.0 MB; behaviour files are limited to 1024 KiB")


def test_missing_file_and_folder(tmp_path: Path) -> None:
    for path, message in ((tmp_path / "nope.yaml", "no such behaviour file"),
                          (tmp_path, "is a folder, not a behaviour file")):
        with pytest.raises(LabsimError) as e:
            load(path)
        assert [(d.path, d.line, d.message) for d in e.value.diagnostics] == [(str(path), 0, message)]


SAVE = "save the file as UTF-8 (most editors: File > Save with Encoding > UTF-8)"


def test_not_utf8_is_shown_at_the_byte_and_named(tmp_path: Path) -> None:
    p = tmp_path / "latin.yaml"
    p.write_bytes(b"labsim: 1\n# \xc3\xa9t\xc3\xa9 caf\xe9\nname: x\n")
    with pytest.raises(LabsimError) as e:
        load(p)
    (d,) = e.value.diagnostics
    assert (d.line, d.col) == (2, 10)  # characters: the two UTF-8 'é' before it are one column each
    assert d.message == f"byte 0xE9 is not UTF-8 text (it reads as 'é' in Latin-1): {SAVE}"
    assert d.format().splitlines()[1:] == ["    2 | # été caf\ufffd", "      |          ^"]


@pytest.mark.parametrize("data, line, col, message", [
    (b"\xef\xbb\xbfa: \x92x\n", 1, 4, f"byte 0x92 is not UTF-8 text (it reads as '\u2019' in Windows-1252): {SAVE}"),
    (b"\xff\xfea\x00:\x00", 1, 1, f"this file is UTF-16 text: {SAVE}"),
    (b"a: 1\r\nb: \x81\r\n", 2, 4, f"byte 0x81 is not UTF-8 text: {SAVE}"),
])
def test_not_utf8_variants(tmp_path: Path, data: bytes, line: int, col: int, message: str) -> None:
    p = tmp_path / "b.yaml"
    p.write_bytes(data)
    with pytest.raises(LabsimError) as e:
        load(p)
    (d,) = e.value.diagnostics
    assert (d.line, d.col, d.message) == (line, col, message)


def test_not_utf8_world_file_shows_no_byte_and_no_line(tmp_path: Path) -> None:
    p = tmp_path / "w.yaml"
    p.write_bytes(b"labsim-world: 1\nsecret: caf\xe9\n")
    with pytest.raises(LabsimError) as e:
        load(p, kind="world")
    (d,) = e.value.diagnostics
    assert (d.line, d.col, d.message, d.source_line) == (2, 12, f"not UTF-8 text: {SAVE}", "")


def test_a_utf8_file_with_a_byte_order_mark_loads(tmp_path: Path) -> None:
    p = tmp_path / "b.yaml"
    p.write_bytes(b"\xef\xbb\xbfname: caf\xc3\xa9\n")
    assert load(p).text == "name: café\n"


def test_over_indented_rule_merged_into_the_previous_one(write) -> None:
    path = write(HEAD + "rules:\n  - if sonar5 <= 0.5 then arc(-2, 2)\n    - else move(1)\n")
    ((line, col, message, notes),) = compile_problems(path)
    assert (line, col) == (8, 5)
    assert message == "expected ',' between actions, found '-'"
    assert notes == ("hint: YAML joined line 8 onto this rule; if line 8 is a rule of its own, "
                     "indent its '-' like the one above",)


def test_a_colon_makes_yaml_read_a_mapping(write) -> None:
    path = write(HEAD + "rules:\n  - if sonar5 < 1: stop()\n  - else move(1)\n")
    ((line, col, message, notes),) = compile_problems(path)
    assert (line, col, message) == (7, 5, "a rule must be text such as 'if COND then ACTION', not a mapping")
    assert "because of the ': '" in notes[0]


def test_unknown_top_level_key_lists_the_known_ones(write) -> None:
    path = write(HEAD + "rulez:\n  - always stop()\nrules:\n  - always stop()\n")
    ((line, col, message, notes),) = compile_problems(path)
    assert (line, col, message) == (6, 1, "unknown key 'rulez' (did you mean 'rules'?)")
    assert notes[0].startswith("known keys: labsim, name, description, world, dt, seed, stop")


def test_deep_nesting_is_an_error_not_a_crash(write) -> None:
    path = write(HEAD + "rules:\n  - if " + "(" * 1000 + "sonar5" + ")" * 1000 + " < 1 then stop()\n"
                 + "  - if " + "-" * 1000 + "sonar5 < 1 then stop()\n  - else move(1)\n")
    found = compile_problems(path)
    assert len(found) == 1  # parentheses alone nest nothing: only the 1000 minus signs are too deep
    line, col, message, _ = found[0]
    assert (line, message) == (8, "expression nested too deeply (more than 100 levels)")


def test_empty_and_non_mapping_files(write) -> None:
    assert compile_problems(write(""))[0][2].startswith("the file is empty")
    assert compile_problems(write("- a\n- b\n"))[0][2].startswith("a behaviour file is a YAML mapping")


def test_a_number_too_large_for_a_float_is_refused_where_it_is_written(write) -> None:
    huge = "1" + "0" * 400
    path = write(f"labsim: 1\nworld: walls_lab4\nstop: time >= 1\nseed: {huge}\n"
                 f"robots: {{p: {{model: pioneer_p3dx}}}}\nrules: ['always move(1)']\nparams: {{front: -{huge}}}\n")
    found = compile_problems(path)
    assert [(line, col) for line, col, _, _ in found] == [(4, 7), (7, 17)]
    assert all(message.startswith("number too large") for _, _, message, _ in found)


def test_a_let_that_is_no_mapping_is_reported_once(write) -> None:
    path = write("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots: {p: {model: pioneer_p3dx}}\n"
                 "rules: ['always move(1)']\nlet: [a, b]\n")
    assert [m for _, _, m, _ in compile_problems(path)] == ["let must be a mapping of names to values, not a list"]
