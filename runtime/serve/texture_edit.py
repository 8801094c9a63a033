"""The stand-in's textures: ``sim.createTexture`` and ``sim.writeTexture`` in ``labsim serve --empty``.

Where it sits: ``scene_edit.SceneEditor`` takes these calls among its edits (this class is
one of its bases); a textured plane is a ``built.Shape`` of kind ``texture`` holding its
picture as PNG bytes, which ``built.read_shapes`` turns into the ground labsim's cameras see.
``labsim scene`` sends a painted floor as data (a blank texture, then ``sim.writeTexture``),
which a CoppeliaSim on another machine can take; a file on the server's own disk is read only
from the folders a client may read (docs/security.md, "The server").
"""
from __future__ import annotations

import math
from typing import Any

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.files import read_served
from labsim.runtime.serve.built import MAX_SIZE_M, Shape
from labsim.runtime.serve.mechanism_edit import floats
from labsim.runtime.serve.sim_args import E_ARGS, E_FEW, Args, SimError, as_handle, shown
from labsim.runtime.serve.simulation import Client

MAX_TEXTURE_PX = 4096  # a texture's side: labsim's largest painted floor (road_loop) is 2570 pixels


class TextureEdits:
    """The texture calls of the scene editor; it gives them its shapes and ``_new``."""

    shapes: dict[int, Shape]
    server: Any  # scene_edit.Host
    dirty: bool

    def _new(self, shape: Shape) -> list[object]:
        raise NotImplementedError  # scene_edit.SceneEditor's

    def _createTexture(self, client: Client, args: Args) -> list[object]:
        # sim.createTexture(string fileName, int options, list planeSizes, list scalingUV, list xy_g,
        # int fixedResolution, list resolution): CoppeliaSim 4.6; returns the textured plane's
        # handle, the texture's id (here the plane's handle) and its resolution. An empty
        # fileName: a blank texture of that resolution (default 512 x 512), for sim.writeTexture
        import cv2
        import numpy as np

        if len(args) < 3 or not isinstance(args[0], str):
            raise SimError(E_FEW if len(args) < 3 else E_ARGS)
        sizes = floats(args[2], 2)
        if not all(math.isfinite(v) and 0 < v <= MAX_SIZE_M for v in sizes):
            raise SimError(f"labsim serve: a texture's plane sizes are finite numbers of metres, greater than 0 and "
                           f"at most {MAX_SIZE_M:g}, not {', '.join(f'{v:g}' for v in sizes)}")
        if args[0] == "":
            res = [as_handle(v) for v in floats(args[6], 2)] if len(args) > 6 and args[6] is not None else [512, 512]
            if not all(1 <= v <= MAX_TEXTURE_PX for v in res):
                raise SimError(f"labsim serve: a texture is 1 to {MAX_TEXTURE_PX} pixels a side, not "
                               f"{res[0]} x {res[1]}")
            ok, encoded = cv2.imencode(".png", np.zeros((res[1], res[0], 3), np.uint8))
            assert ok
            png, (width, height) = encoded.tobytes(), res
        else:
            try:  # the one way in, kept to the folders a client may read (docs/security.md, "The server")
                png = read_served(args[0], self.server.folder, "texture")
            except LabsimError as e:
                raise SimError(f"labsim serve: cannot read the texture '{shown(args[0])}': "
                               f"{e.diagnostics[0].message}") from None
            picture = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
            if picture is None:
                raise SimError(f"labsim serve: the texture '{shown(args[0])}' is not an image")
            height, width = picture.shape[:2]
        [h] = self._new(Shape("texture", (sizes[0], sizes[1], 0.0), alias="Plane", png=png, px=(width, height)))
        return [h, h, [width, height]]

    def _writeTexture(self, client: Client, args: Args) -> list[object]:
        # sim.writeTexture(int textureId, int options, buffer data, int posX = 0, int posY = 0,
        # int sizeX = 0, int sizeY = 0, float interpol = 0): CoppeliaSim 4.6; RGB rows in the
        # texture's order (the first row is the picture's top, as a file loads); a size of 0:
        # the whole texture
        import cv2
        import numpy as np

        if len(args) < 3:
            raise SimError(E_FEW)
        shape = self.shapes.get(as_handle(args[0]))
        data = args[2].encode() if isinstance(args[2], str) else args[2]
        if shape is None or shape.kind != "texture":
            raise SimError("texture does not exist.")
        if not isinstance(data, (bytes, bytearray)):
            raise SimError(E_ARGS)
        nums = [as_handle(a) if a is not None else 0 for a in args[3:7]] + [0] * 4
        width, height = shape.px
        x, y = (nums[0], nums[1])
        w, h = (nums[2] or width, nums[3] or height)
        x, y = (0 if nums[2] == 0 else x), (0 if nums[3] == 0 else y)
        if w < 0 or h < 0 or w > MAX_TEXTURE_PX or h > MAX_TEXTURE_PX or len(data) < 3 * w * h:
            raise SimError(f"labsim serve: sim.writeTexture of {w} x {h} pixels needs {3 * w * h} bytes of RGB, "
                           f"was given {len(data)}")
        decoded = cv2.imdecode(np.frombuffer(shape.png, np.uint8), cv2.IMREAD_COLOR)
        assert decoded is not None  # the stand-in's own encoding of the texture
        picture = cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)
        patch = np.frombuffer(bytes(data[:3 * w * h]), np.uint8).reshape(h, w, 3)
        x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, width), min(y + h, height)
        if x1 > x0 and y1 > y0:  # the part inside the texture, as CoppeliaSim writes it
            picture[y0:y1, x0:x1] = patch[y0 - y:y1 - y, x0 - x:x1 - x]
        ok, encoded = cv2.imencode(".png", cv2.cvtColor(picture, cv2.COLOR_RGB2BGR))
        assert ok
        shape.png = encoded.tobytes()
        self.dirty = True
        return [1]
