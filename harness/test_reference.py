"""Reference results inside each FMU (FMI-LS-REF 1.0.0-alpha.1, as the Reference FMUs ship them):
``extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml`` names ``<Name>_ref.csv``, the outputs
of the default experiment ("time" and at most 10 Real outputs, quoted names, no units), and
``<Name>_in.csv``, the load history they were computed under (the scene's ``experiment.loads``).

Reference numbers: a fresh ``simulate_fmu(fmu, input=fmpy.util.read_csv(<Name>_in.csv))`` of the
FMI 2 and of the FMI 3 archive, the input read back from the archive with fmpy's own reader.
The packer ran the same engine through the same calls (initial equilibrium under the first
input row, one step per row under the input interpolated with fmpy's formula), so the columns
must agree bit for bit. The ``_ref.csv`` files are regression artefacts recorded by
``velarium pack``; what verifies the numbers themselves is the rest of the harness
(docs/mechanics.md).
"""

from __future__ import annotations

import csv
import io
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

import fmpy
import fmpy.util
import numpy as np
import pytest

import fmi3_support as f3
import velarium_run as vr

FOLDER = "extra/org.fmi-standard.fmi-ls-ref"
LS = "{http://fmi-standard.org/fmi-ls-manifest}"


def manifest_of(fmu) -> list[tuple[str, str, str]]:
    manifest = ET.fromstring(vr.fmu_member(fmu, f"{FOLDER}/fmi-ls-manifest.xml"))
    assert manifest.tag == "fmiReferences"
    assert manifest.get(f"{LS}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
    return [(r.get("source"), r.get("role"), r.get("type")) for r in manifest.findall("Related")]


def parse_cell(text: str):
    """A CSV cell: one number, or an array's elements space-separated (fmpy's convention)."""
    values = [float(x) for x in text.split(" ")]
    return values[0] if len(values) == 1 else np.array(values)


def reference_of(fmu) -> tuple[list[str], list[list]]:
    md = fmpy.read_model_description(str(fmu))
    name = md.coSimulation.modelIdentifier
    assert manifest_of(fmu) == [(f"{name}_ref.csv", "result", "text/csv"), (f"{name}_in.csv", "input", "text/csv")]
    text = vr.fmu_member(fmu, f"{FOLDER}/{name}_ref.csv").decode()
    header_line = text.splitlines()[0]
    assert re.fullmatch(r'"[^"]*"(,"[^"]*")*', header_line), header_line  # every name quoted
    rows = list(csv.reader(io.StringIO(text)))
    header = rows[0]
    assert header[0] == "time" and 1 <= len(header) - 1 <= 10
    assert not any("[" in h and "]" not in h for h in header)  # no unit suffixes
    return header, [[parse_cell(x) for x in row] for row in rows[1:]]


def input_of(fmu, tmp_path) -> np.ndarray:
    """The archive's reference input, read with fmpy's CSV reader (what `fmpy simulate
    --input-file` does)."""
    md = fmpy.read_model_description(str(fmu))
    name = md.coSimulation.modelIdentifier
    path = tmp_path / f"{name}_in.csv"
    path.write_bytes(vr.fmu_member(fmu, f"{FOLDER}/{name}_in.csv"))
    return fmpy.util.read_csv(str(path))


def archive_of(fmu, version):
    archive = fmu if version == "fmi2" else f3.fmi3_path(fmu)
    if not archive.is_file():
        pytest.skip(f"{archive} is missing")
    return archive


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_reference_result_equals_a_fresh_run_under_the_shipped_input(fmu, version, tmp_path):
    archive = archive_of(fmu, version)
    header, reference = reference_of(archive)
    md = fmpy.read_model_description(str(archive))
    reals = [v.name for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")]
    assert header[1:] == reals[:10], "the first (at most) 10 Real outputs in table order"
    signals = input_of(archive, tmp_path)
    result = fmpy.simulate_fmu(str(archive), input=signals, output=header[1:])
    assert len(result) == len(reference)
    assert np.array_equal(result["time"], [row[0] for row in reference])
    for k, name in enumerate(header[1:], start=1):
        for i, row in enumerate(reference):
            assert np.array_equal(np.ravel(result[name][i]), np.ravel(row[k])), f"{name} at row {i}"  # row-major


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_the_shipped_input_moves_the_structure(fmu, version, tmp_path):
    """The input history leaves its start values and the reference outputs follow it: some
    output changes from the initial row to the last, and from the second row on every row
    differs from the one before (each shipped history changes the loads at every step)."""
    archive = archive_of(fmu, version)
    md = fmpy.read_model_description(str(archive))
    signals = input_of(archive, tmp_path)
    assert signals.size >= 2
    starts = {v.name: float(v.start) for v in md.modelVariables if v.causality == "input" and not v.dimensions}
    moved = [n for n in signals.dtype.names[1:] if np.any(signals[n] != signals[n][0])]
    assert moved, f"the input file holds its first row: {signals}"
    for n in signals.dtype.names[1:]:
        if n in starts:
            assert signals[n][0] == starts[n], f"{n} starts at {signals[n][0]}, its start value is {starts[n]}"
    _, reference = reference_of(archive)
    values = [np.concatenate([np.atleast_1d(c) for c in row[1:]]) for row in reference]
    assert not np.array_equal(values[0], values[-1]), "the reference ends where it started"
    for i in range(2, len(values)):
        assert not np.array_equal(values[i], values[i - 1]), f"row {i} repeats row {i - 1}"


@pytest.mark.parametrize("name", ["PrestressedCable", "ZonedCushion"])
def test_fmpy_simulate_command_with_the_input_file(name, tmp_path):
    """The documented command: `fmpy simulate X.fmu --input-file X_in.csv` (the FMI 3 archive of
    ZonedCushion: an array input) writes the reference rows."""
    fmu = vr.FMU_DIR / (f"{name}.fmu" if name == "PrestressedCable" else f"{name}_fmi3.fmu")
    if not fmu.is_file():
        pytest.skip(f"{fmu} is missing")
    (tmp_path / f"{name}_in.csv").write_bytes(vr.fmu_member(fmu, f"{FOLDER}/{name}_in.csv"))
    header, reference = reference_of(fmu)
    cli = vr.Path(sys.executable).with_name("fmpy")
    run = subprocess.run([str(cli), "simulate", str(fmu), "--input-file", f"{name}_in.csv", "--output-file", "out.csv",
                          "--output-variables", *header[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    written = fmpy.util.read_csv(str(tmp_path / "out.csv"))
    assert len(written) == len(reference)
    for k, column in enumerate(header[1:], start=1):
        for i, row in enumerate(reference):
            if np.ndim(row[k]) == 0:
                # fmpy's write_csv prints a scalar with repr: the exact number.
                assert written[column][i] == row[k], f"{column} at row {i}"
            else:
                # ... and an array's elements with "%.16g": 16 significant digits, a relative
                # rounding of at most 5e-16.
                assert np.allclose(written[column][i], row[k], rtol=1e-15, atol=0), f"{column} at row {i}"
