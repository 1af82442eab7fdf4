"""`velarium schema` carries the rules of `velarium check` that JSON Schema can state (issue 28):
ranges, the format version and the name patterns, so that an editor validating a scene against
it flags what check rejects.

SOURCE: the schema printed by `velarium schema` (generated from `src/scene/rules.rs`, whose
numbers are the validator's own constants); the validator is `jsonschema`'s Draft 2020-12
validator (an implementation the project did not write); the reference verdict is `velarium
check`. No tolerance: every verdict is compared exactly.

- The schema is a valid Draft 2020-12 schema, and every shipped scene and example passes it.
- A set of wrong scenes (a negative EA, format 2, a node index of -1, a Poisson's ratio of 0.5,
  ...) is flagged by the schema at the field that is wrong, and rejected by check.
- The two name patterns give check's verdict on a set of names.
- What JSON Schema cannot state stays with check: node 99 of a 3-node mesh passes the schema
  (the node count is another field) and check rejects it.
"""

from __future__ import annotations

import copy
import json
import subprocess
from pathlib import Path

import pytest

import velarium_run as vr

jsonschema = pytest.importorskip("jsonschema")

SHIPPED = sorted([*vr.SCENES.glob("*/scene.json"), *(vr.ROOT / "examples").glob("*.json")])

TINY = {
    "format": 1,
    "name": "TinyCable",
    "geometry": {"nodes": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]},
    "cables": [{"name": "c", "nodes": [0, 1, 2], "EA": 1e5, "pretension": 100}],
    "supports": [{"nodes": [0, 2], "fix": ["x", "y", "z"]}, {"nodes": [1], "fix": ["y"]}],
    "inputs": [{"name": "F", "load": {"kind": "point_force", "nodes": [1], "direction": [0, 0, -1]}}],
    "outputs": [{"name": "w", "probe": {"kind": "displacement", "node": 1, "component": "z"}}],
}

SHEET = {
    "format": 1,
    "name": "Sheet",
    "geometry": {"generators": [{"kind": "annulus", "name": "ring", "center": [0, 0, 0],
                                 "inner_radius": 0.5, "outer_radius": 1, "rings": 2, "sectors": 12}]},
    "membranes": [{"name": "m", "triangles": "ring", "thickness": 0.001,
                   "material": {"kind": "svk", "E": 1e9, "nu": 0.3}}],
    "supports": [{"nodes": "ring.boundary", "fix": ["x", "y", "z"]}],
    "inputs": [{"name": "p", "load": {"kind": "pressure", "membrane": "m"}}],
}


@pytest.fixture(scope="module")
def schema():
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    out = subprocess.run([str(vr.VELARIUM), "schema"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


@pytest.fixture(scope="module")
def validator(schema):
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def check(velarium, scene: dict, tmp_path: Path) -> subprocess.CompletedProcess:
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    return subprocess.run([str(velarium), "check", str(path)], capture_output=True, text=True)


def flagged(validator, scene: dict) -> list[str]:
    """The JSON paths the schema's errors are about, with those inside a oneOf or anyOf (a
    tagged object's variants, a list of ids or a set name): their context holds the error of
    each branch, down to the field."""
    def paths(errors):
        for e in errors:
            yield ".".join(str(p) for p in e.absolute_path)
            yield from paths(e.context or [])
    return list(paths(validator.iter_errors(scene)))


def test_the_schema_is_draft_2020_12(schema, validator):
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.parent.name if p.name == "scene.json" else p.name)
def test_every_shipped_scene_passes_the_schema(validator, path):
    scene = json.loads(path.read_text())
    assert flagged(validator, scene) == []


def changed(base: dict, path: list, value):
    scene = copy.deepcopy(base)
    node = scene
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return scene


# (base scene, path of the field, wrong value): each is an error of check and of the schema.
WRONG = [
    (TINY, ["cables", 0, "EA"], -5),
    (TINY, ["cables", 0, "EA"], 0),
    (TINY, ["cables", 0, "pretension"], -1),
    (TINY, ["format"], 2),
    (TINY, ["name"], "1Cable"),
    (TINY, ["name"], "Tiny-Cable"),
    (TINY, ["cables", 0, "nodes", 1], -1),
    (TINY, ["cables", 0, "nodes", 1], 1.5),
    (TINY, ["cables", 0, "name"], "my cable"),
    (TINY, ["geometry", "nodes", 1, 0], 2e30),
    (TINY, ["inputs", 0, "name"], "time"),
    (TINY, ["outputs", 0, "name"], "1w"),
    (TINY, ["solver"], {"tolerance": 1}),
    (TINY, ["solver"], {"tolerance": 1e-15}),
    (TINY, ["solver"], {"max_iterations": 0}),
    (TINY, ["solver"], {"max_iterations": 4294967296}),
    (TINY, ["solver"], {"threads": 65}),
    (TINY, ["solver"], {"prestress_continuation": 0.2}),
    (TINY, ["solver"], {"limits": {"max_memory_gb": 0}}),
    (TINY, ["experiment"], {"start_time": 0, "stop_time": 1, "step_size": -0.1}),
    (SHEET, ["membranes", 0, "material", "nu"], 0.5),
    (SHEET, ["membranes", 0, "material", "E"], -2e9),
    (SHEET, ["membranes", 0, "thickness"], 0),
    (SHEET, ["membranes", 0, "residual_stiffness"], 0.5),
    (SHEET, ["membranes", 0, "prestress"], {"kind": "isotropic", "n": 0}),
    (SHEET, ["membranes", 0, "prestress"], {"kind": "isotropic", "n": 2e12}),
    (SHEET, ["geometry", "generators", 0, "sectors"], 2),
    (SHEET, ["geometry", "generators", 0, "rings"], 0),
    (SHEET, ["geometry", "generators", 0, "name"], "the ring"),
    (SHEET, ["form_finding"], {"homotopy": 1}),
    (SHEET, ["form_finding"], {"tolerance": 0.1}),
]


@pytest.mark.parametrize("base,path,value", WRONG, ids=[f"{'.'.join(map(str, p))}={v}" for _, p, v in WRONG])
def test_wrong_scenes_are_flagged_by_the_schema_and_check(velarium, validator, tmp_path, base, path, value):
    scene = changed(base, path, value)
    where = flagged(validator, scene)
    field = ".".join(str(p) for p in path)
    assert any(w == field or w.startswith(field + ".") for w in where), f"schema: {where}"
    assert check(velarium, scene, tmp_path).returncode == 1


@pytest.mark.parametrize("name", ["A", "_x", "Tiny_2", "1a", "a-b", "é", "a b", "a.b", ""])
def test_the_identifier_pattern_is_checks(velarium, validator, tmp_path, name):
    scene = changed(TINY, ["name"], name)
    by_schema = "name" not in flagged(validator, scene)
    by_check = check(velarium, scene, tmp_path).returncode == 0
    assert by_schema == by_check


@pytest.mark.parametrize("name", ["w", "w.x", "w[1]", "[w]", "_1", "time", "timer", "1w", ".w", "w-x", "w x", ""])
def test_the_variable_name_pattern_is_checks(velarium, validator, tmp_path, name):
    scene = changed(TINY, ["outputs", 0, "name"], name)
    by_schema = "outputs.0.name" not in flagged(validator, scene)
    by_check = check(velarium, scene, tmp_path).returncode == 0
    assert by_schema == by_check


def test_what_the_schema_cannot_state_stays_with_check(velarium, validator, tmp_path):
    """Node 99 of a 3-node mesh: the node count is the length of another list (or comes from a
    generator), which JSON Schema cannot relate to an index."""
    scene = changed(TINY, ["cables", 0, "nodes", 1], 99)
    assert flagged(validator, scene) == []
    result = check(velarium, scene, tmp_path)
    assert result.returncode == 1
    assert "cables[0].nodes[1]: unknown node 99: the mesh has 3 nodes" in result.stdout
