"""The lidar: its beams' directions, its readings in a room, its key, its noise and its trace."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from helpers import examples, run_example

from labsim.backends.protocol import RobotRequest
from labsim.backends.pymunk.backend import PymunkBackend
from labsim.backends.scene.models import PIONEER_P3DX, Kind, Lidar
from labsim.backends.scene.world import Pose, Wall, World
from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError

FACE, THICK = 2.0, 0.1


def room() -> World:
    c, e = FACE + THICK / 2, FACE + THICK
    walls = (Wall((-e, -c), (e, -c), THICK), Wall((c, -e), (c, e), THICK),
             Wall((e, c), (-e, c), THICK), Wall((-c, e), (-c, -e), THICK))
    return World("room", "test room", (-FACE, -FACE, FACE, FACE), walls)


def test_a_full_circle_reads_every_direction_once_and_beam_181_looks_ahead() -> None:
    angles = [math.degrees(a) for a in Lidar(360, 360, 5).angles_rad()]
    assert angles[0] == -180 and angles[180] == 0 and angles[90] == -90 and angles[270] == 90
    assert len(set(round(a, 9) for a in angles)) == 360
    fan = [math.degrees(a) for a in Lidar(5, 90, 5).angles_rad()]
    assert fan == pytest.approx([-45, -22.5, 0, 22.5, 45])  # a fan includes both ends
    assert [math.degrees(a) for a in Lidar(1, 30, 5).angles_rad()] == [0]


def test_beams_read_the_distance_to_the_walls_of_a_room() -> None:
    """From the room's centre, facing +x: ahead, left, right and behind are FACE away; a
    diagonal is FACE * sqrt(2) (inf when the range is shorter)."""
    model = dataclasses.replace(PIONEER_P3DX, lidars=(Lidar(360, 360, 5.0),))
    channels = tuple(f"lidar{k}" for k in (1, 46, 91, 181, 271))
    b = PymunkBackend()
    b.open(room(), [RobotRequest("p", model, Pose(0.0, 0.0, 0.0), channels)], 0.05, seed=1)
    back, right_back, right, ahead, left = b.sense()[0]
    assert [back, right, ahead, left] == pytest.approx([FACE] * 4, abs=1e-9)
    assert right_back == pytest.approx(FACE * math.sqrt(2), abs=1e-9)
    b.close()
    short = dataclasses.replace(PIONEER_P3DX, lidars=(Lidar(360, 360, 2.5),))
    b = PymunkBackend()
    b.open(room(), [RobotRequest("p", short, Pose(0.0, 0.0, 0.0), ("lidar46", "lidar181"))], 0.05, seed=1)
    assert b.sense()[0] == [math.inf, pytest.approx(FACE, abs=1e-9)]
    b.close()


def test_the_channels_are_distances_after_the_sonars() -> None:
    model = dataclasses.replace(PIONEER_P3DX, lidars=(Lidar(4, 360, 5.0),))
    channels = model.channels()
    names = list(channels)
    assert names[16:20] == ["lidar1", "lidar2", "lidar3", "lidar4"] and channels["lidar3"] is Kind.DISTANCE


def test_the_docs_obstacle_avoidance_example_runs_without_a_collision(tmp_path: Path) -> None:
    assert "lidar_avoid" in examples("worlds.md")
    run, summary, warned = run_example("lidar_avoid", tmp_path, trace=True, doc="worlds.md")
    assert warned == []
    assert summary.robots["pioneer"].contacts == 0
    header = (tmp_path / "t.csv").read_text().splitlines()[1].split(",")
    assert "nearest" in header and not any(c.startswith("lidar") for c in header)  # beams are not traced
    assert summary.robots["pioneer"].metrics["closest"] > 0.2


def _behaviour(tmp_path: Path, lidar: str, rules: str = "always move(1)") -> Path:
    path = tmp_path / "b.yaml"
    path.write_text(f"labsim: 1.2\nworld: walls_lab4\nseed: 2\nstop: time >= 2\n"
                    f"robots:\n  p: {{model: pioneer_p3dx, at: [0, 0, 0], lidar: {lidar}}}\n"
                    f"let:\n  near: min(lidar1..lidar8)\nrules:\n  - {rules}\n")
    return path


@pytest.mark.parametrize(("lidar", "message"), [
    ("{beams: 0}", "b.yaml:6:58: error: lidar beams must be between 1 and 1440, not 0"),
    ("{beams: 8, fov_deg: 400}", "lidar fov_deg must be between 1 and 360, not 400"),
    ("{beams: 8, range: 3}", "unknown key 'range' in the lidar of robot 'p'"),
    ("{beams: 8.5}", "lidar beams"),
])
def test_a_wrong_lidar_is_an_error_at_its_value(tmp_path: Path, lidar: str, message: str) -> None:
    with pytest.raises(LabsimError) as e:
        compile_file(_behaviour(tmp_path, lidar))
    assert message in str(e.value) and "not exist" not in str(e.value)  # the beams' uses stay quiet


def test_a_beam_the_lidar_does_not_have_is_an_unknown_sensor(tmp_path: Path) -> None:
    with pytest.raises(LabsimError) as e:
        compile_file(_behaviour(tmp_path, "{beams: 4}"))
    assert "b.yaml:8:13: error: lidar1..lidar8 names lidar5 .. lidar8, which do not exist" in str(e.value)
    assert "names of this kind: lidar1 .. lidar4" in str(e.value)


def test_lidar_noise_is_seeded_and_changes_only_echoes(tmp_path: Path) -> None:
    from labsim.backends import load_backend
    from labsim.runtime.run import Run

    def readings(lidar: str) -> list[list[float]]:
        run = Run(compile_file(_behaviour(tmp_path, lidar)), load_backend("pymunk"), warn=lambda m: None)
        out = []
        for _ in range(5):
            out.append(list(run.sense()[0][:8]))
            run.tick()
        run.close()
        return out
    clean, noisy, again = (readings(f"{{beams: 8, range_m: 10{n}}}") for n in ("", ", noise: 0.05", ", noise: 0.05"))
    assert noisy == again and noisy != clean
    assert all(abs(a - b) < 0.5 for r, s in zip(clean, noisy) for a, b in zip(r, s) if math.isfinite(a))
