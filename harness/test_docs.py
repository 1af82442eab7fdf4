"""What a user reads is true of a clone: every relative link of README.md and docs/*.md points to
a file (and heading) in the repository, nothing in them, the harness, Cargo.toml or .ci/ points to
notes outside it, docs/README.md maps every page of docs/, every complete scene in README.md and
docs/scenes.md passes `velarium check`, and `velarium schema` states the unit of every load kind
and the sign of pressure."""

from __future__ import annotations

import json
import re
import subprocess

import pytest

import velarium_run as vr

# Names of the founding engineers' notes, which are not in a clone (spelled in pieces so that
# this file does not cite them itself).
NOTES = ["MECHANICS" + ".md", "../" + "shared", "FMI" + ".md", "STYLE" + ".md", "LINEAR_ALGEBRA" + ".md",
         "DESIGN" + ".md", "ANCHORS" + ".md"]
DOCS = [vr.ROOT / "README.md", *sorted((vr.ROOT / "docs").glob("*.md"))]


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path):
    return {slug(m.group(1)) for m in re.finditer(r"^#+ (.*)$", path.read_text(), re.M)}


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_links_resolve_inside_the_repository(doc):
    text = doc.read_text()
    assert not [n for n in NOTES if n in text], doc.name
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+://", target):
            continue
        file, _, anchor = target.partition("#")
        path = (doc.parent / file).resolve() if file else doc
        assert path.is_file(), f"{doc.name}: link to {target}: no such file"
        if anchor and path.suffix == ".md":
            assert anchor in anchors(path), f"{doc.name}: link to {target}: no such heading"


def test_the_harness_cites_only_the_repository():
    paths = [*(vr.ROOT / "harness").glob("*.py"), *(vr.ROOT / "harness").glob("*.sh"),
             vr.ROOT / "Cargo.toml", *(p for p in (vr.ROOT / ".ci").iterdir() if p.is_file())]
    for path in paths:
        text = path.read_text()
        assert not [n for n in NOTES if n in text], path.name


def test_the_docs_map_has_a_paragraph_for_every_page():
    """docs/README.md is the map of docs/: each page is linked from a paragraph of its own that
    starts with the link, and the map links to no page that does not exist."""
    text = (vr.ROOT / "docs" / "README.md").read_text()
    pages = {p.name for p in (vr.ROOT / "docs").glob("*.md")} - {"README.md"}
    mapped = set(re.findall(r"^\*\*\[[^\]]+\]\(([^)#]+\.md)\)", text, re.M))
    assert pages <= mapped, f"docs/README.md has no paragraph for {sorted(pages - mapped)}"
    assert mapped <= pages, f"docs/README.md maps pages that do not exist: {sorted(mapped - pages)}"


def scenes_in(path):
    blocks = re.findall(r"```json\n(.*?)```", path.read_text(), re.S)
    return [b for b in blocks if '"format": 1' in b]


@pytest.mark.parametrize("doc", [vr.ROOT / "README.md", vr.ROOT / "docs" / "scenes.md"], ids=lambda p: p.name)
def test_every_complete_scene_passes_check(doc, tmp_path):
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing")
    scenes = scenes_in(doc)
    assert scenes, f"{doc.name} shows no complete scene"
    for k, text in enumerate(scenes):
        path = tmp_path / f"scene{k}.json"
        path.write_text(text)
        run = subprocess.run([str(vr.VELARIUM), "check", str(path)], capture_output=True, text=True)
        assert run.returncode == 0, f"{doc.name}, scene {k}:\n{run.stdout}{run.stderr}"


def test_schema_states_units_and_the_pressure_sign():
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing")
    schema = json.loads(subprocess.run([str(vr.VELARIUM), "schema"], capture_output=True, text=True, check=True).stdout)
    loads = {v["properties"]["kind"]["const"]: v["description"] for v in schema["$defs"]["Load"]["oneOf"]}
    assert set(loads) == {"point_force", "pressure", "displacement", "radial_edge_load", "volume", "gas",
                          "rotation", "polar_displacement", "zone_pressure", "support_displacement",
                          "snow", "self_weight", "ponding", "water_volume"}
    assert "in N " in loads["point_force"] and "in Pa" in loads["pressure"]
    assert "in m " in loads["displacement"] and "in N/m" in loads["radial_edge_load"]
    assert "in m³" in loads["volume"] and "closed" in loads["volume"]
    assert "in m³" in loads["gas"] and "closed" in loads["gas"]
    assert "in Pa" in loads["snow"] and "plan area" in loads["snow"]
    assert "in m/s²" in loads["self_weight"] and "in m " in loads["ponding"] and "gamma_w" in loads["ponding"]
    assert "in m³" in loads["water_volume"] and "water_level" in loads["water_volume"]
    assert "in rad " in loads["rotation"] and "in m " in loads["polar_displacement"]
    assert "in Pa" in loads["zone_pressure"] and "in m " in loads["support_displacement"]
    assert "counter-clockwise" in loads["pressure"] and "positive" in loads["pressure"]
