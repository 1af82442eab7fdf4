"""The shipped FMUs under the Reference FMUs' `fmusim` (optional: set FMUSIM to its executable).

fmusim is not in the package registries CI reaches; docs/fmu.md ("Reference results inside the
FMU", **fmusim.**) says how to build it from the Reference-FMUs sources against the
distribution's zlib, libxml2, minizip and SUNDIALS packages; `bash harness/build_fmusim.sh
REFERENCE_FMUS_CHECKOUT` builds it (CVode stubbed: Model Exchange only). Without FMUSIM every
test here skips with that reason.

What is compared (measured with fmusim 0.0.39, docs/fmu.md):

- fmusim interpolates an input as ``x0 + (t - t0) * (x1 - x0) / (t1 - t0)``; the reference
  results were recorded under fmpy's interpolation, which rounds differently (SleeveCable's
  force at t = 1 s: fmusim 1, fmpy 0.9999999999999998). Given fmpy's input values at every
  communication point (a dense input file, so fmusim interpolates nothing), fmusim prints every
  cell of the reference exactly: its CSV carries 16 significant digits (``%.16g``), so each
  printed number equals the reference rounded to 16 digits.
- Under the shipped input file itself, those input roundings move the engine's equilibria by
  its solver noise: at most 3.1e-12 of a column's largest magnitude (a column of round-off
  zeros, AnnulusTorsion's hub_force, by 1.7e-12 absolute). The bound here is 1e-11 times the
  larger of 1 and the column's largest magnitude.
- The state-file options end in an error, never in a crash: fmusim passes the state itself
  where `fmi2FreeFMUstate` / `fmi3FreeFMUState` take its address, which the FMU refuses with an
  error (docs/fmu.md, "State"); bytes that are not a state, or another FMU's state, are
  refused when deserialized.
"""

from __future__ import annotations

import csv
import io
import os
import shutil
import subprocess
from pathlib import Path

import fmpy
import fmpy.util
import numpy as np
import pytest
from fmpy.simulation import Input

import velarium_run as vr
from test_reference import FOLDER, archive_of, reference_of

FMUSIM = os.environ.get("FMUSIM", "")
NOISE = 1e-11  # measured: 3.1e-12 (SleeveCable's tension_start)


def fmusim() -> str:
    if not FMUSIM:
        pytest.skip("FMUSIM is not set: build fmusim from the Reference-FMUs sources (docs/fmu.md) and set FMUSIM to it")
    path = shutil.which(FMUSIM)
    if path is None:
        pytest.skip(f"FMUSIM={FMUSIM} is not an executable")
    return path


def run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    done = subprocess.run([fmusim(), *args], cwd=cwd, capture_output=True, text=True, timeout=600)
    # A signal (segfault, abort) is a negative return code: never acceptable.
    assert done.returncode >= 0, f"fmusim died with signal {-done.returncode}: {done.stdout}{done.stderr}"
    return done


def rows_of(text: str) -> list[list[str]]:
    return list(csv.reader(io.StringIO(text)))


def cell(text: str) -> np.ndarray:
    return np.array([float(x) for x in text.split(" ")])


def simulate(archive: Path, header: list[str], input_file: str, cwd: Path) -> list[list[str]]:
    args = ["--input-file", input_file, "--output-file", "out.csv"]
    for name in header[1:]:
        args += ["--output-variable", name]
    done = run([*args, str(archive)], cwd)
    assert done.returncode == 0, done.stdout + done.stderr
    rows = rows_of((cwd / "out.csv").read_text())
    assert rows[0] == header
    return rows[1:]


def shipped_input(archive: Path, tmp_path: Path) -> str:
    name = fmpy.read_model_description(str(archive)).coSimulation.modelIdentifier
    (tmp_path / "in.csv").write_bytes(vr.fmu_member(archive, f"{FOLDER}/{name}_in.csv"))
    return "in.csv"


def dense_input(archive: Path, tmp_path: Path) -> str:
    """fmpy's input values (Input.interpolate, what the reference run set) at every
    communication point of the default experiment, written exactly (repr)."""
    signals = fmpy.util.read_csv(str(tmp_path / shipped_input(archive, tmp_path)))
    experiment = fmpy.read_model_description(str(archive)).defaultExperiment
    start, stop, step = float(experiment.startTime), float(experiment.stopTime), float(experiment.stepSize)
    times = [start + k * step for k in range(int(round((stop - start) / step)) + 1)]
    names = signals.dtype.names[1:]
    tables = [np.reshape(signals[n], (len(signals), -1)).T.astype(float) for n in names]
    lines = [",".join(f'"{n}"' for n in signals.dtype.names)]
    for t in times:
        cells = [repr(t)]
        for table in tables:
            values, _ = Input.interpolate(t, signals["time"], table)
            cells.append(" ".join(repr(float(v)) for v in values))
        lines.append(",".join(cells))
    (tmp_path / "dense.csv").write_text("\n".join(lines) + "\n")
    return "dense.csv"


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_fmusim_prints_the_reference_under_fmpys_input_values(fmu, version, tmp_path):
    archive = archive_of(fmu, version)
    header, _ = reference_of(archive)
    name = fmpy.read_model_description(str(archive)).coSimulation.modelIdentifier
    reference = rows_of(vr.fmu_member(archive, f"{FOLDER}/{name}_ref.csv").decode())[1:]
    written = simulate(archive, header, dense_input(archive, tmp_path), tmp_path)
    assert len(written) == len(reference)
    for i, (row, ref) in enumerate(zip(written, reference)):
        for k, name in enumerate(header):
            printed = np.array([float("%.16g" % v) for v in cell(ref[k])])
            assert np.array_equal(cell(row[k]), printed), f"{name} at row {i}: {row[k]} != {ref[k]}"


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_fmusim_under_the_shipped_input_file_is_within_solver_noise(fmu, version, tmp_path):
    archive = archive_of(fmu, version)
    header, reference = reference_of(archive)
    written = simulate(archive, header, shipped_input(archive, tmp_path), tmp_path)
    assert len(written) == len(reference)
    assert [float(r[0]) for r in written] == [float("%.16g" % r[0]) for r in reference]
    for k, name in enumerate(header[1:], start=1):
        got = np.array([cell(r[k]) for r in written])
        want = np.array([np.atleast_1d(r[k]) for r in reference])
        scale = max(1.0, float(np.abs(want).max()))
        worst = float(np.abs(got - want).max())
        assert worst <= NOISE * scale, f"{name}: {worst:.3g} > {NOISE} * {scale:.3g}"


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_fmusim_state_file_options_end_in_errors_not_crashes(fmu, version, tmp_path):
    archive = archive_of(fmu, version)
    free = "fmi2FreeFMUstate" if version == "fmi2" else "fmi3FreeFMUState"
    deserialize = "fmi2DeSerializeFMUstate" if version == "fmi2" else "fmi3DeserializeFMUState"
    misplaced = f"[Error] {free}: the FMU state argument 0x"
    # fmusim's exit code for an FMI error is 3 (fmi2Error / fmi3Error).

    # --final-fmu-state-file: the state is serialized and written, then freed with the state
    # where its address belongs: an error with the FMU's message.
    final = run(["--final-fmu-state-file", "state.bin", "--output-file", "out.csv", str(archive)], tmp_path)
    assert final.returncode == 3 and misplaced in final.stdout + final.stderr, final.stdout + final.stderr
    assert (tmp_path / "state.bin").read_bytes()[:8] == b"VLRMSTAT"

    # --initial-fmu-state-file with that state: deserialized (same GUID), then the same free.
    initial = run(["--initial-fmu-state-file", "state.bin", "--output-file", "out.csv", str(archive)], tmp_path)
    assert initial.returncode == 3 and misplaced in initial.stdout + initial.stderr, initial.stdout + initial.stderr

    # Bytes that are not a state.
    (tmp_path / "junk.bin").write_bytes(b"junk\n")
    junk = run(["--initial-fmu-state-file", "junk.bin", "--output-file", "out.csv", str(archive)], tmp_path)
    assert junk.returncode == 3, junk.stdout + junk.stderr
    assert f"[Error] {deserialize}: length check failed" in junk.stdout + junk.stderr

    # Another FMU's state (the other FMI version's archive has another GUID).
    other = fmu if version == "fmi3" else archive_of(fmu, "fmi3")
    run(["--final-fmu-state-file", "other.bin", "--output-file", "out.csv", str(other)], tmp_path)
    foreign = run(["--initial-fmu-state-file", "other.bin", "--output-file", "out.csv", str(archive)], tmp_path)
    assert foreign.returncode == 3, foreign.stdout + foreign.stderr
    assert f"[Error] {deserialize}: GUID check failed" in foreign.stdout + foreign.stderr
