"""Messages for mistakes students make: each with its place (path:line:col), exit code 2 and no traceback.

The checker's own cases are ``*_with_error.yaml`` fixtures (tests/unit/test_check.py); these are the
ones seen through the command line or at run time.
"""
from __future__ import annotations

from pathlib import Path

from helpers import FIXTURES, ROOT

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.runtime.cli.main import main
from labsim.runtime.run import Run


def cli(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def test_a_fault_in_a_let_is_reported_at_the_let_not_at_the_rule_that_reads_it(tmp_path: Path) -> None:
    path = tmp_path / "lab.yaml"
    path.write_text("labsim: 1\nworld: walls_lab4\nstop: time >= 0.2\nrobots:\n  p: {model: pioneer_p3dx}\n"
                    "let:\n  b: 1 / (time - time)\nrules:\n  - if b > 1 then move(1)\n  - else move(2)\n")
    warned: list[str] = []
    Run(compile_file(path), load_backend("pymunk"), warn=warned.append).run()
    assert len(warned) == 1
    first = warned[0].splitlines()
    assert first[0] == f"{path}:7:6: warning: division by zero in signal 'b', robot p, tick 0"
    assert first[1:3] == ["    7 |   b: 1 / (time - time)", "      |      ^~~~~~~~~~~~~~~~~"]


def test_a_world_file_given_as_a_behaviour_says_so_once(capsys) -> None:
    world = ROOT / "backends" / "scene" / "worlds" / "walls_lab4.yaml"
    code, _, err = cli(capsys, "run", str(world))
    assert code == 2
    assert err.count(": error: ") == 1
    assert ":4:1: error: this is a world file, not a behaviour: a behaviour names it with 'world:'" in err
    assert "run a behaviour with 'world: walls_lab4' in it" in err


def test_an_unclosed_quote_shows_its_line_and_a_caret(capsys) -> None:
    code, _, err = cli(capsys, "check", str(FIXTURES / "yaml_quote_with_error.yaml"))
    assert code == 2
    assert err.splitlines()[1:3] == ['    6 | stop: "time >= 1', "      |       ^"]


def test_too_many_random_robots_fail_check_at_the_robot_line(capsys) -> None:
    code, _, err = cli(capsys, "check", str(FIXTURES / "crowd_with_error.yaml"))
    assert code == 2
    assert "crowd_with_error.yaml:9:3: error: no free place left in world 'walls_lab4' for robot 'p[88]'" in err
    assert "walls_lab4.yaml" not in err


def test_a_latin1_byte_in_a_comment_is_shown_where_it_is_with_the_fix(capsys, tmp_path: Path) -> None:
    path = tmp_path / "lab.yaml"
    path.write_bytes(b"labsim: 1\n# mur du caf\xe9\nworld: walls_lab4\nstop: time >= 1\nrobots:\n"
                     b"  p: {model: pioneer_p3dx}\nrules:\n  - always move(1)\n")
    for command in ("check", "run"):
        code, out, err = cli(capsys, command, str(path))
        assert code == 2
        assert err.splitlines() == [
            f"{path}:2:13: error: byte 0xE9 is not UTF-8 text (it reads as 'é' in Latin-1): save the file as "
            "UTF-8 (most editors: File > Save with Encoding > UTF-8)",
            "    2 | # mur du caf\ufffd",
            "      |             ^",
        ]
