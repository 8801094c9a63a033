"""What a client of ``labsim serve`` may make it read: ``sim.createTexture`` names a file, and
the stand-in reads it the one way in (foundation/files.py), only in the folder the server
started in, in ``labsim scene``'s scratch folders and in ``--allow-path`` folders
(docs/security.md, "The server"). Anything else is refused with an error the client sees."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import cv2
import numpy as np
import pytest

cbor2 = pytest.importorskip("cbor2")
pytest.importorskip("zmq")

from labsim.backends.scene.world import World  # noqa: E402
from labsim.backends.scene.world_file import load_world  # noqa: E402
from labsim.backends.scene.world_names import builtin_worlds  # noqa: E402
from labsim.foundation.diagnostics import Report  # noqa: E402
from labsim.foundation.files import ALLOW_ENV, SCRATCH_PREFIX  # noqa: E402
from labsim.runtime.serve.server import Server  # noqa: E402

REFUSED = "is outside the folders labsim serve reads"


def _png(path: Path, size: tuple[int, int] = (8, 4)) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.full((size[1], size[0], 3), 200, np.uint8))
    return path


def _texture(server: Server, name: str) -> dict:
    """One sim.createTexture request, straight to the server, as the socket would give it."""
    request = {"func": "sim.createTexture", "args": [name, 0, [1.0, 1.0]], "argsL": 3, "uuid": "student",
               "ver": 2, "lang": "python", "timeout": 600}
    return cbor2.loads(server.handle(cbor2.dumps(request)))


@pytest.fixture
def served(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Server, Path]:
    """An empty stand-in started in tmp_path/served, with no --allow-path."""
    folder = tmp_path / "served"
    folder.mkdir()
    monkeypatch.chdir(folder)
    monkeypatch.delenv(ALLOW_ENV, raising=False)
    return Server(World("none", "", (0, 0, 1, 1)), 0, port=0, empty=True), folder


def test_a_texture_in_the_servers_folder_is_read(served: tuple[Server, Path]) -> None:
    server, folder = served
    _png(folder / "sub" / "floor.png")
    for name in ("sub/floor.png", str(folder / "sub" / "floor.png")):
        reply = _texture(server, name)
        assert "err" not in reply, reply
        assert reply["ret"][2] == [8, 4]


def test_a_texture_outside_the_allowed_folders_is_refused(served: tuple[Server, Path], tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    server, folder = served
    secret = _png(tmp_path / "private" / "photo.png")
    (folder / "link.png").symlink_to(secret)
    for name in (str(secret), "../private/photo.png", "link.png", "/etc/passwd"):
        err = _texture(server, name).get("err", "")
        assert err.startswith(f"labsim serve: cannot read the texture '{name}': {REFUSED}"), err
        assert "--allow-path" in err and "(in function 'sim.createTexture'" in err
    monkeypatch.setenv(ALLOW_ENV, str(secret.parent))  # labsim serve --allow-path DIR
    assert "err" not in _texture(server, str(secret))


def test_no_file_is_waited_on_nor_quoted_whole(served: tuple[Server, Path]) -> None:
    server, folder = served
    if hasattr(os, "mkfifo"):
        os.mkfifo(folder / "pipe.png")  # a bare open() would wait here for a writer, and every client with it
        assert "is a FIFO (named pipe), not a texture file" in _texture(server, "pipe.png")["err"]
    assert "no such texture file" in _texture(server, "gone.png")["err"]
    (folder / "notes.png").write_text("not a picture")
    assert "the texture 'notes.png' is not an image" in _texture(server, "notes.png")["err"]
    long = "x" * 5000 + ".png"
    assert len(_texture(server, long)["err"]) < 600  # a reply does not grow with the request


def test_labsim_scenes_scratch_folder_is_read_and_no_other_temporary_one(served: tuple[Server, Path]) -> None:
    server, _ = served
    with tempfile.TemporaryDirectory(prefix=SCRATCH_PREFIX) as scratch:
        assert "err" not in _texture(server, str(_png(Path(scratch) / "ground.png")))
        deeper = _png(Path(scratch) / "sub" / "ground.png")  # only right inside it
        assert REFUSED in _texture(server, str(deeper))["err"]
    with tempfile.TemporaryDirectory(prefix="other-") as other:
        assert REFUSED in _texture(server, str(_png(Path(other) / "ground.png")))["err"]


def test_the_road_labs_ground_still_reaches_the_stand_in(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``labsim scene`` writes the ground's picture to a scratch folder and names it in
    sim.createTexture: the stand-in, started elsewhere, reads it and shows it to cameras."""
    pytest.importorskip("coppeliasim_zmqremoteapi_client")
    from labsim.backends.coppeliasim.connection import Connection
    from labsim.runtime.builder.scene import build

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(ALLOW_ENV, raising=False)
    world = load_world(builtin_worlds()["road_loop"], Report())
    assert world is not None and world.ground is not None
    with Server(World("none", "", (0, 0, 1, 1)), 0, port=0, empty=True) as srv:
        build(Connection("127.0.0.1", srv.port, 5.0), world, [], 0.05)
        assert srv.editor is not None
        built = srv.editor.world()
    assert built.ground is not None and built.ground.texture is not None
