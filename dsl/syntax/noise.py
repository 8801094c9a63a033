"""Noise a robot group declares: the ``noise:`` key of a robot, read into plain data.

Part of reading a behaviour file (``labsim.dsl.syntax.read`` calls ``read_noise`` for each robot
that has the key); the models are applied at run time by ``labsim.runtime.noise``, between
the backend and the compiled program, so they are the same on every backend. This module
holds the key tables (``labsim.dsl.syntax.schema`` builds the JSON Schema from them), each model's
limits and units, the reader that checks them with positions, and ``resolve_noise``, with
which the checker replaces a parameter named in place of a number (format 1.2) by its value
after ``--set``, for each member of the group.
"""
from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass

from yaml.nodes import Node, ScalarNode

from labsim.foundation.diagnostics import did_you_mean
from labsim.foundation.source import Reader, scalar_value

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


# "sonar.std_m" -> the Noise field it sets
_FIELDS = {key: key.replace("wheels.", "wheel.").replace(".", "_") for key in LIMITS}


@dataclass(frozen=True)
class NoiseDecl:
    """A group's ``noise:`` as written: each key's number, or the parameter that gives it (format 1.2)."""

    values: tuple[tuple[str, float | str, Node], ...]  # ("sonar.dropout", 0.05 or "drop", the value's node)

    @property
    def names(self) -> frozenset[str]:
        """The parameters it names."""
        return frozenset(v for _, v, _ in self.values if isinstance(v, str))


_TABLES = {"sonar": SONAR_NOISE_KEYS, "camera": CAMERA_NOISE_KEYS, "wheels": WHEEL_NOISE_KEYS}


def read_noise(r: Reader, node: Node, robot: str, has_camera: bool, names: bool = False) -> NoiseDecl:
    """``noise: {sonar: {std_m, dropout}, camera: {std}, wheels: {std_rad_s, slip}}`` of a robot.

    With ``names`` (format 1.2) a value may be a parameter's name, resolved by the checker
    (``resolve_noise``). Every problem is reported at its key or value, which is left out.
    """
    values: list[tuple[str, float | str, Node]] = []
    models = r.fields(node, NOISE_KEYS, f"the noise of robot '{robot}' (keys: {', '.join(NOISE_KEYS)})") or {}
    for model, body in models.items():
        if model == "camera" and not has_camera:
            r.error(body, f"robot '{robot}' has no camera to add noise to",
                    notes=("give it one with 'camera:', or remove the camera noise",))
            continue
        keys = _TABLES[model]
        for key, value in (r.fields(body, keys, f"{model} noise (keys: {', '.join(keys)})") or {}).items():
            what = f"{model} noise {key}"
            text = scalar_value(value) if isinstance(value, ScalarNode) else None
            if isinstance(text, str):  # a word: a parameter's name, from format 1.2
                name = _parameter_name(r, value, text, what, names)
                if name is not None:
                    values.append((f"{model}.{key}", name, value))
                continue
            lo, hi, _ = LIMITS[f"{model}.{key}"]
            v = r.number(value, what)
            if v is not None and not lo <= v <= hi:
                r.error(value, f"{what} must be between {lo:g} and {hi:g}, not {v:g}")
            elif v is not None:
                values.append((f"{model}.{key}", v, value))
    # the keys read well go on, so the checker reports the names in them too: every error at once
    return NoiseDecl(tuple(values))


def _parameter_name(r: Reader, node: Node, text: str, what: str, names: bool) -> str | None:
    """A noise value written as text: a parameter's name in format 1.2, else reported."""
    word = text.isidentifier() and text.isascii()
    if not names and word:
        r.error(node, f"{what} must be a number, not '{text}'",
                notes=("from format 1.2 ('labsim: 1.2') it may name a parameter of 'params:' instead",))
        return None
    if not names:
        r.number(node, what)  # the message of format 1.1, as it was
        return None
    if not word:
        r.error(node, f"{what} must be a number or the name of a parameter, not '{text[:40]}'",
                notes=("e.g. 'dropout: drop' with 'params: {drop: 0.05}'; an expression is not allowed here",))
        return None
    return text


# Reports a problem at a node of the file: the checker's ``error``.
ErrorSink = Callable[[Node, str, tuple[str, ...]], None]


def resolve_noise(decl: NoiseDecl, robot: str, count: int, params: Mapping[str, float | bool],
                  own: Mapping[str, tuple[float | bool, ...]], settings: Mapping[str, str],
                  declared: Collection[str], error: ErrorSink, lists: Collection[str] = ()
                  ) -> tuple[Noise | None, ...] | None:
    """Each member's noise, every parameter named replaced by its value; None after a problem.

    ``params`` are the file's values after ``--set`` (``settings``: name -> the value as
    typed), ``own`` the group's own values, one per member, which win for its members as they
    do in expressions. Each key's range applies to the value it resolves to, reported at the
    key's value with where the number came from. ``declared`` are the names 'params:' holds,
    some of them reported wrong already: naming one says nothing more; ``lists`` the list parameters
    among them (format 1.3), which noise cannot take.
    """
    members: list[dict[str, float]] = [{} for _ in range(count)]
    failed = False
    for key, value, node in decl.values:
        if isinstance(value, float):
            for m in members:
                m[_FIELDS[key]] = value
            continue
        model, name = key.split(".")
        what = f"{model} noise {name}"
        if value not in params:
            if value in lists:  # format 1.3: a list parameter
                error(node, f"{what} must be a number, and parameter '{value}' is a list",
                      ("name a parameter that is one number, or write the number",))
            elif value not in declared:
                shown = value if len(value) <= 40 else value[:40] + "..."  # a name can be any length
                error(node, f"unknown parameter '{shown}'{did_you_mean(value, params)}",
                      (f"parameters: {', '.join(params)}" if params else
                       f"declare it under 'params:', e.g. params: {{{shown}: 0.1}}",))
            failed = True
            continue
        per_member = own.get(value, (params[value],) * count)
        if any(isinstance(v, bool) for v in per_member):
            error(node, f"{what} must be a number, and parameter '{value}' is true or false", ())
            failed = True
            continue
        lo, hi, _ = LIMITS[key]
        wrong = sorted({float(v) for v in per_member if not lo <= v <= hi})
        if wrong:
            source = (f"in the 'params:' of robot '{robot}'" if value in own
                      else f"from --set {value}={settings[value][:40]}" if value in settings else "in 'params:'")
            error(node, f"{what} must be between {lo:g} and {hi:g}, not {wrong[0]:g} (parameter '{value}', "
                        f"{source})", ())
            failed = True
            continue
        for m, v in zip(members, per_member, strict=True):
            m[_FIELDS[key]] = float(v)
    if failed:
        return None
    return tuple(Noise(**m) or None for m in members)
