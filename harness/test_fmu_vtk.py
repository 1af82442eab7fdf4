"""A ParaView series from an FMU's array outputs (harness/fmu_vtk.py) equals the series
`velarium solve --vtk` writes for the same loads, read back by VTK (pyvista).

Scene: modelDescription/ZonedCushion/scene.json (81 nodes, 128 triangles, four edge cables) with its bottom
cable's `cable_tensions` output joined by those of the other three cables, so that its outputs
give every field the FMU series can hold. Both archives run the same wind ramp through
`fmpy.simulate_fmu` (FMI 3: arrays; FMI 2: scalars `u[i,j]`); fmpy's row k+1 is the
equilibrium under the loads of row k (the one-step lag), which is `velarium solve`'s row k. The
engine is the same, so every number agrees bit for bit: points, cells, displacement_m,
wrinkle_state, sigma_max_Pa, sigma_min_Pa and cable_tension_N with `np.array_equal`.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

import fmu_vtk
import velarium_run as vr

pyvista = pytest.importorskip("pyvista")

SCENE = vr.ROOT / "modelDescription" / "ZonedCushion" / "scene.json"
WIND = [(0.0, 0.0, 0.0), (0.25, 100.0, 50.0), (0.5, 200.0, 100.0), (0.75, 300.0, -100.0)]
COMPARED = ("displacement_m", "wrinkle_state", "sigma_max_Pa", "sigma_min_Pa", "cable_tension_N",
            "kind", "id", "cable")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """(FMI 2 archive, FMI 3 archive, the CLI's series) of the scene with every cable's tensions."""
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    tmp = tmp_path_factory.mktemp("fmu_vtk")
    scene = json.loads(SCENE.read_text())
    for cable in ("edge_right", "edge_top", "edge_left"):
        scene["outputs"].append({"name": f"{cable}_T", "probe": {"kind": "cable_tensions", "cable": cable}})
    path = tmp / "ZonedCushion.json"
    path.write_text(json.dumps(scene))
    run = subprocess.run([str(vr.VELARIUM), "pack", str(path), "--out", str(tmp)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    loads = tmp / "loads.csv"
    loads.write_text("time,wind[1],wind[2]\n" + "".join(f"{t!r},{a!r},{b!r}\n" for t, a, b in WIND))
    run = subprocess.run([str(vr.VELARIUM), "solve", str(path), "--loads", str(loads), "--vtk", str(tmp / "cli"),
                          "--quiet"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return tmp / "ZonedCushion.fmu", tmp / "ZonedCushion_fmi3.fmu", vr.series_files(tmp / "cli" / "ZonedCushion.pvd")


def simulate(fmu: Path) -> np.ndarray:
    fmi3 = fmu.stem.endswith("_fmi3")
    dtype = [("time", float), ("wind", float, (2,))] if fmi3 else [("time", float), ("wind[1]", float), ("wind[2]", float)]
    table = np.zeros(len(WIND), dtype=dtype)
    for k, (t, a, b) in enumerate(WIND):
        table[k] = (t, (a, b)) if fmi3 else (t, a, b)
    return vr.simulate(fmu, vr.extend_by_one_step(table))


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_the_fmu_series_equals_the_cli_series(runs, tmp_path, version):
    fmu = runs[0] if version == "fmi2" else runs[1]
    cli = runs[2]
    result = simulate(fmu)
    pvd = fmu_vtk.write_series(fmu, result, tmp_path / "series")
    series = vr.series_files(pvd)
    assert [t for t, _ in series] == list(result["time"])
    assert sorted(p.name for p in pvd.parent.iterdir()) == sorted([pvd.name] + [p.name for _, p in series]), "no temporary files"
    reader = pyvista.get_reader(str(pvd))
    assert list(reader.time_values) == list(result["time"])
    for k, (_, cli_vtu) in enumerate(cli):
        ours, theirs = pyvista.read(series[k + 1][1]), pyvista.read(cli_vtu)
        assert np.array_equal(ours.points, theirs.points)
        assert np.array_equal(ours.cells, theirs.cells) and np.array_equal(ours.celltypes, theirs.celltypes)
        for name in COMPARED:
            data = ours.point_data if name == "displacement_m" else ours.cell_data
            other = theirs.point_data if name == "displacement_m" else theirs.cell_data
            assert np.array_equal(data[name], other[name], equal_nan=True), (k, name)
        assert list(ours.field_data["TimeValue"]) == [result["time"][k + 1]]
        # Fields no output gives are left out, not made up.
        assert "tension_direction" not in ours.cell_data and "tension_direction" in theirs.cell_data
    last = pyvista.read(series[-1][1])
    assert np.abs(last.point_data["displacement_m"][:, 2]).max() > 0.05, "the test must see a deformation"
    assert np.any(last.cell_data["wrinkle_state"] == 1), "the test must see wrinkles"
    assert not np.any(np.isnan(last.cell_data["cable_tension_N"][last.cell_data["kind"] == 1]))


def test_our_reader_reads_the_cli_files_as_vtk_does(runs):
    """fmu_vtk.read_vtu (no VTK) gives the arrays VTK gives, on the CLI's files."""
    for _, vtu in runs[2]:
        ours, theirs = fmu_vtk.read_vtu(vtu), pyvista.read(vtu)
        assert np.array_equal(ours.points, theirs.points)
        for name, values in {**ours.point_data, **ours.cell_data}.items():
            other = theirs.point_data[name] if name in ours.point_data else theirs.cell_data[name]
            assert np.array_equal(values, other, equal_nan=True), name


def test_the_mesh_resource_names_where_each_output_goes(runs):
    mesh = fmu_vtk.mesh_of(runs[1])
    assert sorted(mesh.field_data) == sorted([
        "displacement_field:u", "principal_stresses:stress", "wrinkle_states:wrinkle",
        "cable_tensions:edge_tension", "cable_tensions:edge_right_T", "cable_tensions:edge_top_T",
        "cable_tensions:edge_left_T"])
    # u covers every mesh node in id order; stress and wrinkle every triangle in model order.
    assert list(mesh.field_data["displacement_field:u"]) == list(range(81))
    assert list(mesh.field_data["principal_stresses:stress"]) == list(range(128))
    # The bottom cable's 8 segments are the 8 line cells of cable 0.
    edge = mesh.field_data["cable_tensions:edge_tension"]
    assert len(edge) == 8 and np.all(mesh.types[edge] == 3) and np.all(mesh.cell_data["cable"][edge] == 0)
    assert list(mesh.cell_data["id"][edge]) == list(range(8))


def test_outputs_that_do_not_place_every_point_are_named(runs, tmp_path):
    result = simulate(runs[1])
    with pytest.raises(ValueError, match=r"output 'u' is not in the recorded rows"):
        fmu_vtk.write_series(runs[1], result[[n for n in result.dtype.names if n != "u"]], tmp_path)
    with pytest.raises(ValueError, match=r"output 'stress' is not in the recorded rows"):
        fmu_vtk.write_series(runs[1], result[["time", "u", "wrinkle", "edge_tension"]], tmp_path)
    # A displacement_field of the four corners only places 4 of the 81 points.
    scene = json.loads(SCENE.read_text())
    scene["outputs"][0]["probe"]["nodes"] = "corners"
    path = tmp_path / "ZonedCushion.json"
    path.write_text(json.dumps(scene))
    run = subprocess.run([str(vr.VELARIUM), "pack", str(path), "--out", str(tmp_path), "--fmi", "3"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    fmu = tmp_path / "ZonedCushion_fmi3.fmu"
    assert list(fmu_vtk.mesh_of(fmu).field_data["displacement_field:u"]) == [0, 8, 72, 80]
    with pytest.raises(ValueError, match=r"the outputs place 4 of the mesh's 81 points; a series needs a displacement_field"):
        fmu_vtk.write_series(fmu, simulate(fmu), tmp_path / "series")
    assert not (tmp_path / "series").exists(), "nothing written"
    # run_main.py (velarium.run) then falls back to `velarium solve --vtk`; with every point
    # placed it does not.
    from velarium.run import series_of_rows

    assert series_of_rows(fmu, simulate(fmu), tmp_path / "series") is None
    rows = simulate(runs[1])
    pvd = series_of_rows(runs[1], rows, tmp_path / "from_rows")
    assert pvd is not None and len(vr.series_files(pvd)) == len(rows)


def test_the_command_line_reads_a_result_csv(runs, tmp_path):
    """`fmu_vtk.py FMU RESULT.csv DIR` on the CSV fmpy writes (FMI 2 scalars, quoted names)
    gives the series write_series gives from the rows in memory."""
    import sys

    from fmpy.util import write_csv

    result = simulate(runs[0])
    write_csv(str(tmp_path / "result.csv"), result)
    run = subprocess.run([sys.executable, str(Path(fmu_vtk.__file__)), str(runs[0]), str(tmp_path / "result.csv"),
                          str(tmp_path / "from_csv")], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    from_csv = vr.series_files(Path(run.stdout.strip()))
    in_memory = vr.series_files(fmu_vtk.write_series(runs[0], result, tmp_path / "in_memory"))
    assert len(from_csv) == len(in_memory) == len(result)
    for (t1, a), (t2, b) in zip(from_csv, in_memory):
        ga, gb = pyvista.read(a), pyvista.read(b)
        assert t1 == t2 and np.array_equal(ga.points, gb.points)
        for name in COMPARED:
            data = (ga.point_data, gb.point_data) if name == "displacement_m" else (ga.cell_data, gb.cell_data)
            assert np.array_equal(data[0][name], data[1][name], equal_nan=True), name
