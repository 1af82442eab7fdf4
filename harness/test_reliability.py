"""Reliability under misuse beyond the checklist: a hand-edited FMU whose resources/scene.json is
broken. (The other reliability tests of issue 5 are checklist items: 2000 runs in one process
is item 47, 1000 reset cycles item 46, ten threads item 11, a strange extraction directory
item 9, NaN / inf / 1e30 inputs item 35, the binary's exports and dependencies item 3.)
"""

from __future__ import annotations

import json
import re
import shutil

import pytest

import fmi_support as fs


def broken_copies(unzipdir, tmp_path):
    """(what, directory, pattern the message must match) for each way to break the scene."""
    scene_text = (unzipdir / "resources" / "scene.json").read_text()
    scene = json.loads(scene_text)
    cases = [("truncated JSON", scene_text[: len(scene_text) // 2], r"scene\.json.*line \d+"),
             ("wrong format", json.dumps({**scene, "format": 99}), r"scene\.json.*format"),
             ("unknown field", json.dumps({**scene, "colour": "red"}), r"scene\.json.*colour")]
    if scene.get("cables"):
        bad = json.loads(scene_text)
        bad["cables"][0]["EA"] = -5
        cases.append(("negative EA", json.dumps(bad), r"scene\.json.*cables\[0\]\.EA"))
    if scene.get("membranes"):
        bad = json.loads(scene_text)
        bad["membranes"][0]["thickness"] = 0
        cases.append(("zero thickness", json.dumps(bad), r"scene\.json.*membranes\[0\]\.thickness"))
    cases.append(("missing scene", None, r"cannot read .*scene\.json"))
    for i, (what, text, pattern) in enumerate(cases):
        copy = tmp_path / f"case{i}"
        shutil.copytree(unzipdir, copy)
        target = copy / "resources" / "scene.json"
        if text is None:
            target.unlink()
        else:
            target.write_text(text)
        yield what, copy, pattern


def test_a_malformed_scene_in_resources_fails_instantiation_with_a_located_message(unzipdir, model_description, tmp_path):
    """Instantiate returns NULL (fmpy raises "Failed to instantiate") and the logger got one
    Error naming the file and the place (JSON line/column or field path); no crash."""
    md = model_description
    for what, copy, pattern in broken_copies(unzipdir, tmp_path):
        fs.clear_log()
        with fs.slave(copy, md, instantiate=False) as s:
            with pytest.raises(Exception, match="Failed to instantiate"):
                s.instantiate(callbacks=fs.CALLBACKS)
        errors = fs.messages(fs.ERROR)
        assert any(re.search(pattern, m, re.S) for m in errors), (what, errors)
