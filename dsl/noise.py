"""Noise a robot group declares: the ``noise:`` key of a robot, read into plain data.

Part of reading a behaviour file (``labsim.dsl.read`` calls ``read_noise`` for each robot
that has the key); the models are applied at run time by ``labsim.runtime.noise``, between
the backend and the compiled program, so they are the same on every backend. This module
holds the key tables (``labsim.dsl.schema`` builds the JSON Schema from them), each model's
limits and units, and the reader that checks them with positions.
"""
from __future__ import annotations

from dataclasses import dataclass

from yaml.nodes import Node

from labsim.foundation.source import Reader

NOISE_KEYS = ("sonar", "camera", "wheels")
SONAR_NOISE_KEYS = ("std_m", "dropout")
CAMERA_NOISE_KEYS = ("std",)
WHEEL_NOISE_KEYS = ("std_rad_s", "slip")

# key -> (lowest, highest, what it is): the limits the reader checks and the schema states
LIMITS: dict[str, tuple[float, float, str]] = {
    "sonar.std_m": (0.0, 10.0, "standard deviation of the Gaussian noise added to each echo, in metres"),
    "sonar.dropout": (0.0, 1.0, "probability that a reading is lost (reads inf, no echo), each tick, "
                                "each sonar"),
    "camera.std": (0.0, 255.0, "standard deviation of the Gaussian noise added to each pixel's colour "
                               "channels, in levels of 0..255"),
    "wheels.std_rad_s": (0.0, 100.0, "standard deviation of the Gaussian noise added to each wheel's "
                                     "command every tick, in rad/s"),
    "wheels.slip": (0.0, 1.0, "the largest fraction of its command a wheel loses each tick (uniform "
                              "between 0 and this)"),
}


@dataclass(frozen=True)
class Noise:
    """A robot's noise models; 0 everywhere is no noise. Units as in ``LIMITS``."""

    sonar_std_m: float = 0.0
    sonar_dropout: float = 0.0
    camera_std: float = 0.0
    wheel_std_rad_s: float = 0.0
    wheel_slip: float = 0.0

    @property
    def sonar(self) -> bool:
        return self.sonar_std_m > 0 or self.sonar_dropout > 0

    @property
    def camera(self) -> bool:
        return self.camera_std > 0

    @property
    def wheels(self) -> bool:
        return self.wheel_std_rad_s > 0 or self.wheel_slip > 0

    def __bool__(self) -> bool:
        return self.sonar or self.camera or self.wheels

    def describe(self) -> str:
        """One line for a summary: 'sonar 0.02 m, 5% dropout; wheels 0.1 rad/s, up to 10% slip'."""
        parts = []
        if self.sonar:
            parts.append("sonar " + ", ".join(
                ([f"{self.sonar_std_m:g} m"] if self.sonar_std_m else [])
                + ([f"{100 * self.sonar_dropout:.3g}% dropout"] if self.sonar_dropout else [])))
        if self.camera:
            parts.append(f"camera {self.camera_std:g} levels")
        if self.wheels:
            parts.append("wheels " + ", ".join(
                ([f"{self.wheel_std_rad_s:g} rad/s"] if self.wheel_std_rad_s else [])
                + ([f"up to {100 * self.wheel_slip:.3g}% slip"] if self.wheel_slip else [])))
        return "; ".join(parts) or "none"

    def header(self) -> dict[str, dict[str, float]]:
        """The models as the trace header records them: only what is set."""
        out: dict[str, dict[str, float]] = {}
        for key, value in (("sonar.std_m", self.sonar_std_m), ("sonar.dropout", self.sonar_dropout),
                           ("camera.std", self.camera_std), ("wheels.std_rad_s", self.wheel_std_rad_s),
                           ("wheels.slip", self.wheel_slip)):
            if value:
                model, name = key.split(".")
                out.setdefault(model, {})[name] = value
        return out


_TABLES = {"sonar": SONAR_NOISE_KEYS, "camera": CAMERA_NOISE_KEYS, "wheels": WHEEL_NOISE_KEYS}


def read_noise(r: Reader, node: Node, robot: str, has_camera: bool) -> Noise | None:
    """``noise: {sonar: {std_m, dropout}, camera: {std}, wheels: {std_rad_s, slip}}`` of a robot.

    Every problem is reported at its key or value; None when there was one.
    """
    errors = r.error_count
    values: dict[str, float] = {}
    models = r.fields(node, NOISE_KEYS, f"the noise of robot '{robot}' (keys: {', '.join(NOISE_KEYS)})") or {}
    for model, body in models.items():
        if model == "camera" and not has_camera:
            r.error(body, f"robot '{robot}' has no camera to add noise to",
                    notes=("give it one with 'camera:', or remove the camera noise",))
            continue
        keys = _TABLES[model]
        for key, value in (r.fields(body, keys, f"{model} noise (keys: {', '.join(keys)})") or {}).items():
            lo, hi, _ = LIMITS[f"{model}.{key}"]
            v = r.number(value, f"{model} noise {key}")
            if v is not None and not lo <= v <= hi:
                r.error(value, f"{model} noise {key} must be between {lo:g} and {hi:g}, not {v:g}")
            elif v is not None:
                values[f"{model}_{key}".replace("wheels_", "wheel_")] = v
    if r.error_count != errors:
        return None
    return Noise(**values)
