"""``labsim lsp`` driven over stdio as an editor drives it (tests/lsp_client.py): diagnostics as
``labsim check --json`` gives them, completion, hover, definition, rename, and a server that
outlives bad requests and huge documents."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from lsp_client import Client

from labsim.runtime.labs import LABS_DIR
from labsim.runtime.lsp.positions import Lines, utf16_len

pytestmark = pytest.mark.slow  # each test starts a server process

WALL = (LABS_DIR / "wall_follow.yaml").read_text(encoding="utf-8")


def _check_json(path: Path) -> list[dict]:
    out = subprocess.run([sys.executable, "-m", "labsim", "check", "--json", str(path)],
                         capture_output=True, text=True, check=False)
    return json.loads(out.stdout)["diagnostics"]


def _line_of(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.split("\n")) if needle in line)


@pytest.fixture
def client():
    c = Client()
    yield c
    c.kill()


def test_a_typo_is_diagnosed_where_check_says_then_the_session_ends(tmp_path: Path, client: Client) -> None:
    text = WALL.replace("min(sonar5, sonar2)", "min(sonr5, sonar2)")
    f = tmp_path / "wall.yaml"
    f.write_text(text, encoding="utf-8")
    client.initialize(tmp_path)
    found = client.wait_diagnostics(client.open(f, text))
    expected = _check_json(f)
    assert len(found) == len(expected) == 1
    d, e = found[0], expected[0]
    assert e["message"] == "unknown name 'sonr5' (did you mean 'sonar5'?)"
    assert d["message"] == e["message"] and d["data"]["hint"] == e["hint"] and d["severity"] == 1
    assert d["range"] == {"start": {"line": e["line"] - 1, "character": e["column"] - 1},
                          "end": {"line": e["line"] - 1, "character": e["end_column"] - 1}}
    assert client.close() == 0


def test_unsaved_text_warnings_and_hints_match_check(tmp_path: Path, client: Client) -> None:
    """The text the editor holds is checked, not the file on disk; warnings and notes too."""
    f = tmp_path / "wall.yaml"
    f.write_text(WALL, encoding="utf-8")
    client.initialize(tmp_path)
    uri = client.open(f, WALL)
    assert client.wait_diagnostics(uri) == []
    edited = WALL.replace("stop: time >= minutes * 60", "stop: time >= minutes * 60\nfoo: 1").replace(
        "  side: 0.3 ", "  unused_p: 2\n  side: 0.3 ")
    client.change(uri, edited, 2)
    found = client.wait_diagnostics(uri)
    saved = tmp_path / "saved.yaml"
    saved.write_text(edited, encoding="utf-8")
    expected = _check_json(saved)
    assert expected and len(found) == len(expected)
    for d, e in zip(found, expected):
        assert d["data"]["message"] == e["message"] and d["data"]["hint"] == e["hint"]
        assert d["message"].split("\n")[0] == e["message"]
        assert d["severity"] == (1 if e["severity"] == "error" else 2)
        assert (d["range"]["start"]["line"], d["range"]["start"]["character"]) == (e["line"] - 1, e["column"] - 1)


def test_a_world_file_beside_it_is_found_from_any_folder(tmp_path: Path) -> None:
    """The server started elsewhere resolves 'world: arena.yaml' from the behaviour's folder, as
    check does; the world file's own mistakes show in it, and on the behaviour's world: line."""
    lab = tmp_path / "lab"
    lab.mkdir()
    world = "labsim-world: 1\nbounds: [0, 0, 4, 4]\nwalls:\n  - [[0, 0], [4, 0], [4, 4, 5]]\n"
    (lab / "arena.yaml").write_text(world, encoding="utf-8")
    text = WALL.replace("world: walls_lab4", "world: arena.yaml")
    (lab / "b.yaml").write_text(text, encoding="utf-8")
    c = Client(cwd=tmp_path.parent)
    try:
        c.initialize(tmp_path)
        expected = _check_json(lab / "b.yaml")
        found = c.wait_diagnostics(c.open(lab / "b.yaml", text))
        assert expected and len(found) == len(expected)
        assert found[0]["data"]["file"] == str(lab / "arena.yaml")
        assert found[0]["message"].startswith(f"{lab / 'arena.yaml'}:{expected[0]['line']}:{expected[0]['column']}: ")
        assert found[0]["range"]["start"]["line"] == _line_of(text, "world: arena.yaml")
        in_world = c.wait_diagnostics(c.open(lab / "arena.yaml", world))
        assert [d["data"]["message"] for d in in_world] == [e["message"] for e in expected]
        assert in_world[0]["range"]["start"] == {"line": expected[0]["line"] - 1,
                                                 "character": expected[0]["column"] - 1}
        assert c.close() == 0
    finally:
        c.kill()


def test_yaml_that_does_not_parse_still_gets_its_diagnostic(tmp_path: Path, client: Client) -> None:
    text = WALL.replace("  front: 0.5 ", "\tfront: 0.5 ")
    f = tmp_path / "tab.yaml"
    f.write_text(text, encoding="utf-8")
    client.initialize(tmp_path)
    found = client.wait_diagnostics(client.open(f, text))
    expected = _check_json(f)
    assert len(found) == len(expected) == 1
    assert found[0]["data"]["message"] == expected[0]["message"]
    assert found[0]["range"]["start"]["line"] == expected[0]["line"] - 1


def test_columns_are_utf16_after_an_emoji(tmp_path: Path, client: Client) -> None:
    text = WALL.replace("  ahead: min(sonar5, sonar2)", '  ahead: min(sonar5, sonar2) if "🤖" == "🤖" else sonr9')
    f = tmp_path / "emoji.yaml"
    f.write_text(text, encoding="utf-8")
    client.initialize(tmp_path)
    found = client.wait_diagnostics(client.open(f, text))
    e = next(x for x in _check_json(f) if "sonr9" in x["message"])
    d = next(x for x in found if "sonr9" in x["message"])
    line = text.split("\n")[e["line"] - 1]
    assert d["range"]["start"]["character"] == utf16_len(line[:e["column"] - 1]) == e["column"] - 1 + 2


def test_completion_hover_definition_and_rename(tmp_path: Path, client: Client) -> None:
    f = tmp_path / "wall.yaml"
    f.write_text(WALL, encoding="utf-8")
    client.initialize(tmp_path)
    uri = client.open(f, WALL)
    client.wait_diagnostics(uri)
    lines = WALL.split("\n")
    n = _line_of(WALL, "  ahead: min(sonar5")
    typing = lines[:]
    typing[n] = "  ahead: min(son"
    client.change(uri, "\n".join(typing), 2)
    answer = client.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                         "position": {"line": n, "character": len(typing[n])}})
    items = {i["label"]: i for i in answer["result"]["items"]}
    assert {f"sonar{k}" for k in range(1, 17)} <= set(items)
    assert "sonar17" not in items
    assert {"ahead", "front", "wander", "follow", "min", "arc", "detected"} <= set(items)
    assert items["clamp"]["detail"] == "clamp(x, lo, hi) -> number"
    g = _line_of(WALL, "goto follow")
    typing = lines[:]
    typing[g] = typing[g][:typing[g].index("goto ") + 5]
    client.change(uri, "\n".join(typing), 3)
    answer = client.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                         "position": {"line": g, "character": len(typing[g])}})
    assert {i["label"] for i in answer["result"]["items"]} == {"wander", "follow"}
    client.change(uri, WALL, 4)

    col = lines[n].index("sonar5")
    hover = client.request("textDocument/hover", {"textDocument": {"uri": uri},
                                                  "position": {"line": n, "character": col + 3}})["result"]
    assert "metres" in hover["contents"]["value"] and "`inf`" in hover["contents"]["value"]
    assert hover["range"] == {"start": {"line": n, "character": col}, "end": {"line": n, "character": col + 6}}
    k = _line_of(WALL, "if ahead <= front or")
    at = {"line": k, "character": lines[k].index("front") + 1}
    hover = client.request("textDocument/hover", {"textDocument": {"uri": uri}, "position": at})["result"]
    assert "**param** `front`" in hover["contents"]["value"] and "0.5" in hover["contents"]["value"]

    s = _line_of(WALL, "stop: time")
    hover = client.request("textDocument/hover", {"textDocument": {"uri": uri},
                                                  "position": {"line": s, "character": 1}})["result"]
    assert hover["contents"]["value"].startswith("**key** `stop` (string or number or boolean): when the run ends")
    target = client.request("textDocument/definition", {"textDocument": {"uri": uri}, "position": at})["result"]
    p = _line_of(WALL, "  front: 0.5")
    assert target == [{"uri": uri, "range": {"start": {"line": p, "character": 2}, "end": {"line": p, "character": 7}}}]

    at = {"line": k, "character": lines[k].index("ahead") + 2}
    edit = client.request("textDocument/rename", {"textDocument": {"uri": uri}, "position": at,
                                                  "newName": "gap"})["result"]
    renamed = _apply(WALL, edit["changes"][uri])
    assert renamed == _renamed_in_code(WALL, "ahead", "gap")
    saved = tmp_path / "renamed.yaml"
    saved.write_text(renamed, encoding="utf-8")
    assert _check_json(saved) == []

    g = _line_of(WALL, "goto follow")
    edit = client.request("textDocument/rename", {"textDocument": {"uri": uri}, "newName": "track",
                                                  "position": {"line": g, "character": lines[g].index("follow")}})
    renamed = _apply(WALL, edit["result"]["changes"][uri])
    assert "goto track" in renamed and "\n  track:\n" in renamed and "state == track and" in renamed
    saved.write_text(renamed, encoding="utf-8")
    assert _check_json(saved) == []
    refused = client.request("textDocument/rename", {"textDocument": {"uri": uri}, "newName": "sonar3",
                                                     "position": {"line": g, "character": lines[g].index("follow")}})
    assert refused["error"]["message"] == "'sonar3' is a built-in or sensor name"
    assert client.close() == 0


def test_an_epuck_and_a_lidar_complete_their_own_sensors(tmp_path: Path, client: Client) -> None:
    text = ("labsim: 1\nworld: walls_lab4\nstop: time > 1\nrobots:\n  e: {model: epuck}\n"
            "  p: {model: pioneer_p3dx, lidar: {beams: 90, range_m: 4}}\nrules:\n  - always move(gr")
    f = tmp_path / "e.yaml"
    client.initialize(tmp_path)
    uri = client.open(f, text)
    end = text.split("\n")
    answer = client.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                         "position": {"line": len(end) - 1, "character": len(end[-1])}})
    labels = {i["label"] for i in answer["result"]["items"]}
    assert {f"prox{k}" for k in range(1, 9)} | {"ground1", "ground2", "ground3"} <= labels
    assert {f"lidar{k}" for k in range(1, 91)} <= labels and "lidar91" not in labels
    assert "prox9" not in labels and "ground4" not in labels


def test_keys_models_and_worlds_complete_from_the_schema(tmp_path: Path, client: Client) -> None:
    client.initialize(tmp_path)
    text = "labsim: 1\nwor\nrobots:\n  p:\n    mo\n    model: \n"
    uri = client.open(tmp_path / "k.yaml", text)

    def labels(line: int, character: int) -> set[str]:
        answer = client.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                             "position": {"line": line, "character": character}})
        return {i["label"] for i in answer["result"]["items"]}

    assert {"world", "robots", "rules", "stop", "let"} <= labels(1, 3)
    assert {"model", "count", "at", "lidar"} <= labels(4, 6)
    assert {"pioneer_p3dx", "epuck"} <= labels(5, 11)
    client.change(uri, "labsim: 1\nworld: \n", 2)
    assert {"walls_lab4", "road_loop"} <= labels(1, 7)
    (tmp_path / "arena.yaml").write_text("labsim-world: 1\nbounds: [0, 0, 4, 4]\n", encoding="utf-8")
    os.mkfifo(tmp_path / "trap.yaml")  # never opened for reading: it would wait for a writer
    (tmp_path / "notes.yaml").write_text("on: push\n", encoding="utf-8")
    found = labels(1, 7)
    assert "arena.yaml" in found and "trap.yaml" not in found and "notes.yaml" not in found


def test_bad_requests_and_a_huge_document_do_not_end_the_server(tmp_path: Path, client: Client) -> None:
    client.initialize(tmp_path)
    uri = client.open(tmp_path / "a.yaml", "labsim: 1\n")
    bad = client.request("textDocument/hover", {"textDocument": {"uri": uri}, "position": {"line": -1, "character": 0}})
    assert bad["error"]["code"] == -32602
    assert "error" in client.request("textDocument/definition", None)
    assert client.request("no/such/method", {})["error"]["code"] == -32601
    far = client.request("textDocument/hover", {"textDocument": {"uri": uri},
                                                "position": {"line": 10 ** 6, "character": 10 ** 6}})
    assert far["result"] is None
    huge = "labsim: 1\n" + "# " + "x" * (1 << 20) + "\n"
    big = client.open(tmp_path / "big.yaml", huge)
    [d] = client.wait_diagnostics(big)
    assert d["message"] == "file is 1.0 MB; behaviour files are limited to 1024 KiB"
    out = tmp_path / "big_on_disk.yaml"
    out.write_text(huge, encoding="utf-8")
    assert [e["message"] for e in _check_json(out)] == [d["message"]]
    answer = client.request("textDocument/completion", {"textDocument": {"uri": big},
                                                         "position": {"line": 1, "character": 3}})
    assert "result" in answer
    assert client.close() == 0


def test_a_request_about_a_file_never_opened_reads_nothing(tmp_path: Path, client: Client) -> None:
    client.initialize(tmp_path)
    on_disk = tmp_path / "closed.yaml"
    on_disk.write_text("labsim: 1\nlet:\n  a: sonar4\n", encoding="utf-8")
    for uri in (on_disk.as_uri(), (tmp_path / "missing.yaml").as_uri()):
        answer = client.request("textDocument/hover", {"textDocument": {"uri": uri},
                                                       "position": {"line": 2, "character": 6}})
        assert answer.get("error") is None and answer["result"] is None
    assert client.request("shutdown", None).get("error") is None
    client.notify("exit", None)
    assert client.proc.wait(timeout=30) == 0
    assert client.proc.stderr is not None and b"Traceback" not in client.proc.stderr.read()


def test_a_yaml_file_that_is_no_labsim_file_gets_no_diagnostics(tmp_path: Path, client: Client) -> None:
    client.initialize(tmp_path)
    assert client.wait_diagnostics(client.open(tmp_path / "ci.yml", "on: push\njobs: {build: {}}\n")) == []


def test_a_client_that_prefers_utf8_gets_utf8_columns(tmp_path: Path) -> None:
    """Neovim offers UTF-8 first: the columns after an emoji count its four bytes."""
    text = WALL.replace("  ahead: min(sonar5, sonar2)", '  ahead: min(sonar5, sonar2) if "🤖" == "🤖" else sonr9')
    f = tmp_path / "emoji.yaml"
    f.write_text(text, encoding="utf-8")
    c = Client()
    try:
        answer = c.request("initialize", {"processId": None, "rootUri": tmp_path.as_uri(),
                                          "capabilities": {"general": {"positionEncodings": ["utf-8", "utf-16"]}}})
        assert answer["result"]["capabilities"]["positionEncoding"] == "utf-8"
        c.notify("initialized", {})
        d = next(x for x in c.wait_diagnostics(c.open(f, text)) if "sonr9" in x["message"])
        e = next(x for x in _check_json(f) if "sonr9" in x["message"])
        assert d["range"]["start"]["character"] == e["column"] - 1 + 2 * 3
        assert c.close() == 0
    finally:
        c.kill()


def test_positions_round_trip_through_utf16() -> None:
    lines = Lines("a: 1\nb: '🤖x'\r\nc")
    assert lines.position(lines.text.index("x")) == (1, 6)
    assert lines.index(1, 6) == lines.text.index("x")
    assert lines.line(1) == "b: '🤖x'" and lines.line(5) == ""
    assert lines.index(99, 0) == len(lines.text)
    utf8 = Lines(lines.text, "utf-8")
    assert utf8.position(lines.text.index("x")) == (1, 8) and utf8.index(1, 8) == lines.text.index("x")


def _renamed_in_code(text: str, old: str, new: str) -> str:
    """The word replaced outside comments (the lab's comments have no '#' in their code)."""
    out = []
    for line in text.split("\n"):
        cut = line.find("#") if "#" in line else len(line)
        out.append(re.sub(rf"\b{old}\b", new, line[:cut]) + line[cut:])
    return "\n".join(out)


def _apply(text: str, edits: list[dict]) -> str:
    lines = Lines(text)
    spans = sorted(((lines.index(e["range"]["start"]["line"], e["range"]["start"]["character"]),
                     lines.index(e["range"]["end"]["line"], e["range"]["end"]["character"]), e["newText"])
                    for e in edits), reverse=True)
    for a, b, new in spans:
        text = text[:a] + new + text[b:]
    return text


def test_an_assignment_file_gets_the_graders_diagnostics_and_keys(tmp_path: Path, client: Client) -> None:
    from labsim.foundation.diagnostics import LabsimError
    from labsim.runtime.grade.assignment import read_assignment

    text = ("labsim-assignment: 1\ntitle: Lab 4\nworld: walls_lab4\nseeds: [1, 2]\ntimout_s: 30\n"
            "criteria:\n  closest: {at_least: 0.2}\n")
    f = tmp_path / "assignment.yaml"
    f.write_text(text, encoding="utf-8")
    with pytest.raises(LabsimError) as raised:
        read_assignment(f)
    client.initialize(tmp_path)
    uri = client.open(f, text)
    found = client.wait_diagnostics(uri)
    assert [(d["data"]["message"], d["data"]["line"], d["data"]["column"]) for d in found] == [
        (e.message, e.line, e.col) for e in raised.value.diagnostics]
    assert any("unknown key 'timout_s'" in d["message"] and d["range"]["start"] == {"line": 4, "character": 0}
               for d in found)
    answer = client.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                         "position": {"line": 4, "character": 3}})
    assert {"timeout_s", "criteria", "budgets", "reference"} <= {i["label"] for i in answer["result"]["items"]}


def test_a_robot_s_name_completes_what_it_can_read_and_say_heard_are_known(tmp_path: Path, client: Client) -> None:
    """Format 1.3: after 'leader.' its pose, its state and the file's signals; say and heard have a signature."""
    text = ("labsim: 1.3\nworld: walls_lab4\nstop: time > 1\nrobots:\n  leader: {model: pioneer_p3dx}\n"
            "  pioneer: {model: pioneer_p3dx, count: 2}\nlet:\n  near: sonar5 < 1\n  a: pioneer[1].")
    client.initialize(tmp_path)
    uri = client.open(tmp_path / "r.yaml", text)
    end = text.split("\n")
    answer = client.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                         "position": {"line": len(end) - 1, "character": len(end[-1])}})
    items = {i["label"]: i for i in answer["result"]["items"]}
    assert list(items) == ["x", "y", "heading", "state", "near", "a"]
    assert items["x"]["detail"] == "pioneer.x"
    answer = client.request("textDocument/completion", {"textDocument": {"uri": uri},
                                                         "position": {"line": len(end) - 1, "character": 5}})
    items = {i["label"]: i for i in answer["result"]["items"]}
    assert items["heard"]["detail"] == "heard(channel[, default]) -> number"
    assert items["say"]["detail"] == "say(channel, value[, range_m])"
