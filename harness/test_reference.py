"""Reference results inside each FMU (FMI-LS-REF 1.0.0-alpha.1, as the Reference FMUs ship them):
``extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml`` names ``<Name>_ref.csv``, the outputs
of the default experiment (inputs at their start values), "time" and at most 10 Real outputs,
quoted names, no units.

Reference numbers: a fresh ``simulate_fmu(fmu)`` with no arguments, of the FMI 2 and of the
FMI 3 archive. The packer ran the same engine through the same calls (initial equilibrium, one
step per row), so the columns must agree bit for bit.
"""

from __future__ import annotations

import csv
import io
import re
import xml.etree.ElementTree as ET

import fmpy
import numpy as np
import pytest

import fmi3_support as f3
import velarium_run as vr

FOLDER = "extra/org.fmi-standard.fmi-ls-ref"
LS = "{http://fmi-standard.org/fmi-ls-manifest}"


def reference_of(fmu) -> tuple[list[str], np.ndarray]:
    md = fmpy.read_model_description(str(fmu))
    name = md.coSimulation.modelIdentifier
    manifest = ET.fromstring(vr.fmu_member(fmu, f"{FOLDER}/fmi-ls-manifest.xml"))
    assert manifest.tag == "fmiReferences"
    assert manifest.get(f"{LS}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
    related = manifest.findall("Related")
    assert [(r.get("source"), r.get("role"), r.get("type")) for r in related] == [
        (f"{name}_ref.csv", "result", "text/csv")]
    text = vr.fmu_member(fmu, f"{FOLDER}/{name}_ref.csv").decode()
    header_line = text.splitlines()[0]
    assert re.fullmatch(r'"[^"]*"(,"[^"]*")*', header_line), header_line  # every name quoted
    rows = list(csv.reader(io.StringIO(text)))
    header = rows[0]
    assert header[0] == "time" and 1 <= len(header) - 1 <= 10
    assert not any("[" in h and "]" not in h for h in header)  # no unit suffixes
    return header, np.array([[float(x) for x in row] for row in rows[1:]])


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_reference_result_equals_a_fresh_run(fmu, version):
    archive = fmu if version == "fmi2" else f3.fmi3_path(fmu)
    if not archive.is_file():
        pytest.skip(f"{archive} is missing")
    header, reference = reference_of(archive)
    md = fmpy.read_model_description(str(archive))
    reals = [v.name for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")]
    assert header[1:] == reals[:10], "the first (at most) 10 Real outputs in table order"
    result = fmpy.simulate_fmu(str(archive), output=header[1:])
    assert len(result) == len(reference)
    assert np.array_equal(result["time"], reference[:, 0])
    for k, name in enumerate(header[1:], start=1):
        assert np.array_equal(result[name], reference[:, k]), name
