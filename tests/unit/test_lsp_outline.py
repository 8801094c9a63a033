"""The language server's map of a behaviour file (runtime/lsp/outline.py): what it declares, and
which words of its expressions are uses of a name."""
from __future__ import annotations

from labsim.runtime.lsp import language
from labsim.runtime.lsp.outline import outline

FILE = """labsim: 1.2
world: walls_lab4
stop: time > 1
robots: {p: {model: pioneer_p3dx}}
functions:
  steer(offset, gain): clamp(gain * offset, -2, 2)
params:
  gain: 2
let:
  offset: sonar1 - 1
  turn: steer(offset, gain)
  near: min(sonar1..sonar8)
rules:
  go:
    - if near < 0.5 then goto back
    - always log("offset {offset:.2f}, near"); move(turn)
  back:
    - if state == back and state_time > 1 then goto go
    - else arc(-1, 1)
"""


def _uses(name: str) -> list[str]:
    found = outline(FILE)
    assert found is not None
    lines = []
    for span in found.occurrences(name, ("signal", "param", "state", "function")):
        line_start = FILE.rfind("\n", 0, span.start) + 1
        lines.append(f"{FILE.count(chr(10), 0, span.start) + 1}:{span.start - line_start + 1}")
    return lines


def test_declarations_and_their_texts() -> None:
    found = outline(FILE)
    assert found is not None and found.kind == "behaviour"
    kinds = {name: [d.kind for d in defs] for name, defs in found.definitions.items()}
    assert kinds == {"p": ["robot"], "steer": ["function"], "gain": ["param"], "offset": ["signal"],
                     "turn": ["signal"], "near": ["signal"], "go": ["state"], "back": ["state"]}
    assert found.definitions["steer"][0].text == "steer(offset, gain): clamp(gain * offset, -2, 2)"
    assert found.definitions["back"][0].text == "if state == back and state_time > 1 then goto go\nelse arc(-1, 1)"
    assert [(r.name, r.model) for r in found.robots] == [("p", "pioneer_p3dx")]
    assert found.world is not None and found.world[0] == "walls_lab4"


def test_uses_skip_a_functions_own_parameters_and_words_in_text() -> None:
    # offset: its key, steer's argument, the {offset} field of the log; not steer's parameter,
    # not the word 'offset' of the log's text
    assert _uses("offset") == ["10:3", "11:15", "16:27"]
    assert _uses("gain") == ["8:3", "11:23"]  # not steer's parameter gain
    assert _uses("back") == ["15:31", "17:3", "18:19"]
    assert _uses("near") == ["12:3", "15:10"]  # not the word near inside the log's text


def test_a_range_of_sensors_names_both_ends() -> None:
    found = outline(FILE)
    assert found is not None
    assert {"sonar1", "sonar8"} <= {name for name, _ in found.references}


def test_yaml_that_does_not_compose_has_no_outline() -> None:
    assert outline("labsim: 1\n\tbad: [\n") is None


def test_sensors_of_each_model() -> None:
    assert [s.name for s in language.sensors("pioneer_p3dx")][:16] == [f"sonar{k}" for k in range(1, 17)]
    epuck = [s.name for s in language.sensors("epuck")]
    assert epuck[:8] == [f"prox{k}" for k in range(1, 9)] and {"ground1", "ground2", "ground3"} <= set(epuck)
    lidar = [s for s in language.sensors("pioneer_p3dx", {"beams": 4, "fov_deg": 180}) if s.name.startswith("lidar")]
    assert [s.name for s in lidar] == ["lidar1", "lidar2", "lidar3", "lidar4"]
    assert "pointing -90°" in lidar[0].doc and "pointing 90°" in lidar[3].doc
    assert "metres" in lidar[0].doc and "`inf` when nothing is seen within 5 m" in lidar[0].doc
    assert language.sensors("r2d2") == []


def test_builtins_have_signatures() -> None:
    b = language.builtins()
    assert b["clamp"].signature == "clamp(x, lo, hi) -> number"
    assert b["min"].signature == "min(number, number, ...) -> number"
    assert b["arc"].signature == "arc(left, right)" and b["arc"].kind == "action"
    assert b["inf"].kind == "constant" and b["state_time"].kind == "variable"
