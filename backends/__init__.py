"""Simulator backends behind one small protocol (``labsim.backends.protocol``).

Backends are registered as "module:Class" strings and imported only when chosen, so the
CoppeliaSim client is never imported by a run on the embedded backend. ``ground_camera`` and
``scene_camera`` are the other ways in: a camera's view of a world's ground, or of the world
with its robots posed by the caller, rendered without a scene, for pictures drawn after a run.
``check_backend`` (``labsim.backends.check``) runs the backend
contract on any backend, a new one's included; it is imported when first asked for.
"""
from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from labsim.backends.protocol import Backend, BackendError

if TYPE_CHECKING:
    import numpy as np

    from labsim.backends.check import BackendContractError as BackendContractError
    from labsim.backends.check import check_backend as check_backend
    from labsim.backends.scene.ground import Ground
    from labsim.backends.scene.models import Camera, RobotModel
    from labsim.backends.scene.world import World

REGISTRY: dict[str, str] = {
    "pymunk": "labsim.backends.pymunk.backend:PymunkBackend",
    "coppeliasim": "labsim.backends.coppeliasim.backend:CoppeliaSimBackend",
}

DEFAULT = "pymunk"

# Cameras on a ground without a running scene, for pictures of a finished run: the same
# lazy "module:function" as the backends, so the runtime still never imports a simulator.
GROUND_CAMERAS: dict[str, str] = {"pymunk": "labsim.backends.pymunk.camera:ground_view"}
# ... and cameras on a world with its robots posed by the caller (a trace's poses)
SCENE_CAMERAS: dict[str, str] = {"pymunk": "labsim.backends.pymunk.scene_view:posed_scene"}


def load_backend(name: str, **options: object) -> Backend:
    """Create the backend registered as ``name`` with its options (``host``, ``port``,
    ``timeout_s`` for coppeliasim); raises BackendError for an unknown name or option."""
    cls = _resolve(REGISTRY, name, f"unknown backend '{name}'")
    accepted = inspect.signature(cls).parameters
    for option in options:
        if option not in accepted:
            raise BackendError(f"backend '{name}' has no option '{option}'"
                               f" (it takes: {', '.join(accepted) or 'none'})")
    return cls(**options)


def ground_camera(ground: Ground, backend: str = DEFAULT) -> Callable[[float, float, float, Camera], np.ndarray]:
    """A renderer of what a camera sees of ``ground``, as the backend ``backend`` draws it:
    ``render(x_m, y_m, heading_rad, camera)`` -> RGB image (row 0 the bottom, CoppeliaSim's order).

    No scene is opened: ``labsim plot --camera`` re-renders a robot's frames from the poses of
    a finished run. Raises BackendError for a backend that cannot render a ground on its own.
    """
    view = _resolve(GROUND_CAMERAS, backend, f"backend '{backend}' cannot render a camera without a scene")(ground)
    render: Callable[[float, float, float, Camera], np.ndarray] = view.render
    return render


SceneRender = Callable[[float, float, float, "Camera", int, Sequence[tuple[float, float, float] | None]], "np.ndarray"]


def scene_camera(ground: Ground, world: World | None, models: Sequence[RobotModel],
                 backend: str = DEFAULT) -> SceneRender:
    """A renderer of what a camera sees of a world with its robots standing where a caller
    says, as the backend draws a run's cameras: ``render(x_m, y_m, heading_rad, camera, robot,
    poses)`` -> RGB image (row 0 the bottom), ``poses`` each robot's (x, y, heading) or None,
    in the order of ``models``, and ``robot`` the index of the one the camera is on.

    No scene is opened (``labsim plot --camera``). Raises BackendError for a backend that
    cannot render a scene on its own.
    """
    view = _resolve(SCENE_CAMERAS, backend, f"backend '{backend}' cannot render a camera without a scene")(
        ground, world, models)
    render: SceneRender = view.render
    return render


def __getattr__(name: str) -> object:
    # The contract check drives whole scenes: importing the registry does not import it.
    if name == "check_backend":
        from labsim.backends.check import check_backend

        return check_backend
    if name == "BackendContractError":
        from labsim.backends.check import BackendContractError

        return BackendContractError
    raise AttributeError(f"module 'labsim.backends' has no attribute '{name}'")


def _resolve(table: dict[str, str], name: str, unknown: str) -> Any:
    """The object a registry's "module:name" string names, imported now; BackendError for a
    name the registry does not have."""
    if name not in table:
        raise BackendError(f"{unknown} (known: {', '.join(sorted(table))})")
    module_name, attribute = table[name].split(":")
    return getattr(importlib.import_module(module_name), attribute)
