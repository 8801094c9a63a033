"""The JSON Schemas (dsl/syntax/schema.py, backends/scene/schema.py): in step with the readers, valid for
every shipped and fixture file, and failing files whose mistake the schema covers."""
from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import jsonschema
import pytest
import yaml
from helpers import BEHAVIOURS, FIXTURES, ROOT

from labsim.backends.scene import mechanism_file, world_file
from labsim.backends.scene.schema import SchemaDrift, mapping
from labsim.dsl.syntax import lidar, noise, read
from labsim.runtime.cli import main as cli
from labsim.runtime.cli.schemas import MODELINE, file_name, schema, schema_text

WORLDS = ROOT / "backends" / "scene" / "worlds"

# each reader table, and where its mapping sits in the schema ("*": any name, "[]": a list's items)
TABLES = [
    ("behaviour", "", read.TOP_KEYS),
    ("behaviour", "robots/*", read.ROBOT_KEYS),
    ("behaviour", "robots/*/camera", read.CAMERA_KEYS),
    ("behaviour", "robots/*/lidar", lidar.LIDAR_KEYS),
    ("behaviour", "robots/*/paths", read.PATH_KEYS),
    ("behaviour", "robots/*/noise", noise.NOISE_KEYS),
    ("behaviour", "robots/*/noise/sonar", noise.SONAR_NOISE_KEYS),
    ("behaviour", "robots/*/noise/camera", noise.CAMERA_NOISE_KEYS),
    ("behaviour", "robots/*/noise/wheels", noise.WHEEL_NOISE_KEYS),
    ("behaviour", "sliders/*", read.SLIDER_KEYS),
    ("behaviour", "metrics/*", read.METRIC_KEYS),
    ("world", "", world_file.KEYS),
    ("world", "walls/[]", world_file.WALL_KEYS),
    ("world", "blocks/[]", world_file.BLOCK_KEYS),
    ("world", "ground", world_file.GROUND_KEYS),
    ("world", "ground/roads/[]", world_file.ROAD_KEYS),
    ("world", "ground/roads/[]/path/[]/arc", world_file.ARC_KEYS),
    ("world", "ground/lines/[]", world_file.LINE_KEYS),
    ("world", "ground/patches/[]", world_file.PATCH_KEYS),
    ("world", "mechanism", mechanism_file.KEYS),
    ("world", "mechanism/bodies/*", mechanism_file.BODY_KEYS),
    ("world", "mechanism/joints/*", mechanism_file.JOINT_KEYS),
    ("world", "mechanism/joints/*/motor", mechanism_file.MOTOR_KEYS),
    ("world", "mechanism/force_sensors/*", mechanism_file.SENSOR_KEYS),
]


def _at(node: dict[str, Any], path: str) -> dict[str, Any]:
    for step in filter(None, path.split("/")):
        if step == "*":
            value = node["additionalProperties"]  # a metric is text or a mapping: the mapping
            node = next((s for s in value.get("anyOf", [value]) if s.get("type") == "object"), value)
        elif step == "[]":
            items = node["items"]
            node = next((s for s in items.get("anyOf", [items]) if s.get("type") == "object"), items)
        else:
            node = node["properties"][step]
    return node


def _objects(node: Any, path: str = "") -> list[str]:
    """The paths of every closed mapping in a schema."""
    out = []
    if isinstance(node, dict):
        if node.get("additionalProperties") is False:
            out.append(path)
        for key, value in node.items():
            out += _objects(value, f"{path}/{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            out += _objects(value, f"{path}/{i}")
    return out


@pytest.mark.parametrize(("kind", "path", "keys"), TABLES, ids=[f"{k}:{p or '/'}" for k, p, _ in TABLES])
def test_every_key_the_reader_accepts_is_in_the_schema_and_no_other(kind: str, path: str,
                                                                    keys: tuple[str, ...]) -> None:
    node = _at(schema(kind), path)
    assert list(node["properties"]) == list(keys)
    assert node["additionalProperties"] is False
    assert all(p.get("description") for p in node["properties"].values())


def test_every_closed_mapping_of_the_schemas_is_a_reader_table() -> None:
    # the "arc" wrapper of a path item is the one mapping with no table of its own
    assert len(_objects(schema("behaviour"))) == 7 + 4
    assert len(_objects(schema("world"))) == 13 + 1


def test_a_table_and_its_descriptions_must_agree() -> None:
    with pytest.raises(SchemaDrift, match="not described: \\['b'\\]"):
        mapping(("a", "b"), {"a": {}})
    with pytest.raises(SchemaDrift, match="described but not read: \\['c'\\]"):
        mapping(("a",), {"a": {}, "c": {}})


def test_the_shipped_schema_files_are_what_labsim_schema_prints(capsys: pytest.CaptureFixture[str]) -> None:
    for kind in ("behaviour", "world"):
        assert cli.main(["schema", kind]) == 0
        printed = capsys.readouterr().out
        assert printed == schema_text(kind) == (BEHAVIOURS / file_name(kind)).read_text(encoding="utf-8")


def test_the_labs_point_editors_at_the_schema() -> None:
    for lab in BEHAVIOURS.glob("*.yaml"):
        first = lab.read_text(encoding="utf-8").splitlines()[0]
        assert first == MODELINE + "behaviour.schema.json"


def _validator(kind: str) -> jsonschema.Draft7Validator:
    s = schema(kind)
    jsonschema.Draft7Validator.check_schema(s)
    return jsonschema.Draft7Validator(s)


def _kind(data: Any) -> str:
    return "world" if isinstance(data, dict) and "labsim-world" in data else "behaviour"


VALID = sorted(BEHAVIOURS.glob("*.yaml")) + sorted(WORLDS.glob("*.yaml")) \
    + sorted(p for p in FIXTURES.glob("*.yaml") if not p.stem.endswith("_with_error"))
# fixtures whose mistakes are names, types of expressions, or rule text: out of the schema's reach
OUT_OF_REACH = sorted(p for p in FIXTURES.glob("*_with_error.yaml")
                      if p.stem not in ("camera_with_error", "crane_with_error", "structure_with_error",
                                        "noise_with_error", "metric_better_with_error", "label_name_with_error",
                                        "yaml_quote_with_error"))  # that one is not YAML at all
COVERED = [FIXTURES / f"{n}.yaml" for n in ("camera_with_error", "crane_with_error", "structure_with_error",
                                            "noise_with_error", "metric_better_with_error",
                                            "label_name_with_error")]


@pytest.mark.parametrize("path", VALID + OUT_OF_REACH, ids=lambda p: p.name)
def test_files_valid_as_far_as_the_schema_sees_validate(path: Path) -> None:
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    errors = list(_validator(_kind(data)).iter_errors(data))
    assert not errors, [e.message for e in errors]


@pytest.mark.parametrize("path", COVERED, ids=lambda p: p.name)
def test_fixtures_with_a_key_or_type_mistake_do_not_validate(path: Path) -> None:
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert list(_validator("behaviour").iter_errors(data))


MUTATIONS = [
    ("behaviour", "wall_follow.yaml", lambda d: d.update(rulez=[])),  # an unknown top-level key
    ("behaviour", "wall_follow.yaml", lambda d: d.update(dt="fast")),  # a number expected
    ("behaviour", "wall_follow.yaml", lambda d: d.update(seed=-1)),  # out of range
    ("behaviour", "road_follow.yaml", lambda d: next(iter(d["robots"].values()))["camera"].update(fov=60)),
    ("behaviour", "road_follow.yaml", lambda d: next(iter(d["robots"].values())).update(count=0)),
    ("behaviour", "crane.yaml", lambda d: next(iter(d["sliders"].values())).update(max="high")),
    ("behaviour", "wall_follow.yaml", lambda d: d["robots"]["pioneer"].update(noise={"sonar": {"dropout": 2}})),
    ("behaviour", "wall_follow.yaml", lambda d: d["robots"]["pioneer"].update(noise={"wheels": {"std": 1}})),
    ("behaviour", "wall_follow.yaml", lambda d: d["metrics"]["following"].update(better="more")),
    ("behaviour", "wall_follow.yaml", lambda d: d["metrics"]["following"].pop("value")),
    ("behaviour", "wall_follow.yaml", lambda d: d["metrics"]["following"].update(best="higher")),
    ("world", "walls_lab4.yaml", lambda d: d.update(bounds=[0, 0, 1])),
    ("world", "road_loop.yaml", lambda d: d["ground"]["roads"][0].update(colour=[1, 2, 3])),
    ("world", "crane.yaml", lambda d: next(iter(d["mechanism"]["joints"].values())).update(kind="hinge")),
    ("world", "crane.yaml", lambda d: next(iter(d["mechanism"]["bodies"].values())).update(shape="sphere")),
]


@pytest.mark.parametrize(("kind", "name", "mutate"), MUTATIONS)
def test_a_key_or_type_mistake_in_a_valid_file_does_not_validate(kind: str, name: str, mutate: Any) -> None:
    folder = BEHAVIOURS if kind == "behaviour" else WORLDS
    data = yaml.safe_load((folder / name).read_text(encoding="utf-8"))
    validator = _validator(kind)
    assert not list(validator.iter_errors(data))
    broken = copy.deepcopy(data)
    mutate(broken)
    assert list(validator.iter_errors(broken))
