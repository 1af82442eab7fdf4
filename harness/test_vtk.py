"""The ParaView series of `velarium solve --vtk DIR` read back by two independent readers
(VTK through pyvista, and harness/fmu_vtk.py's numpy reader) and checked field by field against `velarium solve`'s own CSV outputs and
its --elements CSV of the same run. The files hold zlib-compressed binary f64, and the CSVs
shortest round-trip text, so every comparison is exact unless a tolerance is given: quantities
the test recomputes from the points (lengths, areas, fractions) agree to 1e-12 relative. The
points are the reference positions and `displacement_m` warps them (ParaView's Warp By Vector,
here pyvista's `warp_by_vector`) onto the deformed ones of the --elements CSV, exactly.

Scenes: WrinkledShear (2400 triangles, taut/wrinkled states, reactions), SlidingCable (cables
through a frictionless sleeve: per-segment tensions and slips), SleeveCable (rubber sheet with a
cable in a sleeve: tensions, end slip, lengths).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import fmu_vtk
import velarium_run as vr

pyvista = pytest.importorskip("pyvista")

TABLES = {
    "WrinkledShear": "time,separation,shear\n0,0.001,0\n0.5,0.001,0.001\n1,0.001,0.002\n",
    "SlidingCable": "time,P,p\n0,0,0\n0.5,100,10\n1,200,20\n",
    "SleeveCable": "time,force_2P,cable_preload\n0,0,0.3\n1,1,0.3\n2,2,0.3\n",
}


def solve_with_vtk(name: str, tmp: Path):
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    scene = vr.SCENES / name / "scene.json"
    loads = tmp / "loads.csv"
    loads.write_text(TABLES[name])
    out = tmp / "vtk"
    run = subprocess.run(
        [str(vr.VELARIUM), "solve", str(scene), "--loads", str(loads), "--out", str(tmp / "out.csv"),
         "--elements", str(tmp / "elements.csv"), "--vtk", str(out)],
        capture_output=True, text=True, timeout=600,
    )
    assert run.returncode == 0, run.stderr
    assert run.stderr == "", "no progress line into a pipe"
    rows = vr.read_csv(tmp / "out.csv")
    elements = np.atleast_1d(np.genfromtxt(tmp / "elements.csv", delimiter=",", names=True))
    pvd = out / f"{name}.pvd"
    series = vr.series_files(pvd)
    assert [t for t, _ in series] == list(rows["time"])
    assert sorted(p.name for p in out.iterdir()) == sorted([pvd.name] + [p.name for _, p in series]), "no temporary files"
    return rows, elements, pvd, series


def read_both(vtu: Path):
    """(points, cells by type, point data, cell data) from VTK (pyvista), checked equal to
    harness/fmu_vtk.py's own reader (numpy and zlib, no VTK)."""
    g = pyvista.read(vtu)
    m = fmu_vtk.read_vtu(vtu)
    assert np.array_equal(g.points, m.points)
    assert np.array_equal(g.celltypes, m.types)
    cells = {{5: "triangle", 3: "line"}[t]: c for t, c in g.cells_dict.items()}
    assert g.n_cells == sum(len(c) for c in cells.values())
    cd = {name: np.asarray(g.cell_data[name]) for name in g.cell_data}
    pd = {name: np.asarray(g.point_data[name]) for name in g.point_data}
    assert sorted(cd) == sorted(m.cell_data) and sorted(pd) == sorted(m.point_data)
    for name, values in cd.items():
        assert np.array_equal(m.cell_data[name], values, equal_nan=True), name
    for name, values in pd.items():
        assert np.array_equal(m.point_data[name], values), name
    return g.points, cells, pd, cd


def lines_of(cd: dict, cable: int) -> np.ndarray:
    """Cell indices of one cable's segments, in order along it."""
    idx = np.flatnonzero((cd["kind"] == 1) & (cd["cable"] == cable))
    return idx[np.argsort(cd["id"][idx])]


def test_pvd_is_a_time_series_pyvista_reads(tmp_path):
    rows, _, pvd, series = solve_with_vtk("SlidingCable", tmp_path)
    reader = pyvista.get_reader(str(pvd))
    assert list(reader.time_values) == list(rows["time"])
    reader.set_active_time_value(reader.time_values[-1])
    last = reader.read()[0]
    assert np.array_equal(last.points, fmu_vtk.read_vtu(series[-1][1]).points)
    for time, vtu in series:
        head = vtu.read_bytes()[:400].decode("ascii", "replace")
        assert 'compressor="vtkZLibDataCompressor"' in head and 'header_type="UInt64"' in head
        assert list(pyvista.read(vtu).field_data["TimeValue"]) == [time]


def test_membrane_fields_match_the_elements_csv(tmp_path):
    rows, elements, _, series = solve_with_vtk("WrinkledShear", tmp_path)
    reference = None
    for k, (time, vtu) in enumerate(series):
        points, cells, pd, cd = read_both(vtu)
        tri = cells["triangle"]
        e = elements[elements["time"] == time]
        assert len(e) == len(tri)
        order = np.argsort(cd["id"][: len(tri)])
        assert np.array_equal(cd["id"][: len(tri)][order], e["triangle"].astype(int))
        # Vertices: reference points warped by the displacement (VTK's own Warp By Vector) are
        # the current positions of the CSV; then state, principal stresses, tension direction.
        warped = pyvista.read(vtu).warp_by_vector("displacement_m", factor=1.0).points
        assert np.array_equal(warped, points + pd["displacement_m"])
        for v in range(3):
            assert np.array_equal(warped[tri[order, v]], np.column_stack([e[f"x{v + 1}"], e[f"y{v + 1}"], e[f"z{v + 1}"]]))
        assert np.array_equal(cd["wrinkle_state"][order], e["state"].astype(int))
        assert np.array_equal(cd["sigma_max_Pa"][order], e["sigma_max"])
        assert np.array_equal(cd["sigma_min_Pa"][order], e["sigma_min"])
        assert np.array_equal(cd["tension_direction"][order], np.column_stack([e["tension_x"], e["tension_y"], e["tension_z"]]))
        # The points are the reference configuration: the same in every row, and the
        # deformation is not zero after the first.
        if reference is None:
            reference = points
        assert np.array_equal(points, reference)
        assert k == 0 or np.abs(pd["displacement_m"]).max() > 1e-4
        ref = points
        # The CSV outputs of the same row.
        row = rows[k]
        assert np.max(cd["sigma_max_Pa"][: len(tri)]) == row["max_principal_stress"]
        assert cd["wrinkle_state"][np.flatnonzero(cd["id"][: len(tri)] == 494)[0]] == row["center_state"]
        a = np.cross(ref[tri[:, 1]] - ref[tri[:, 0]], ref[tri[:, 2]] - ref[tri[:, 0]])
        area = 0.5 * np.linalg.norm(a, axis=1)
        for state, output in ((1, "wrinkled_fraction"), (2, "slack_fraction")):
            fraction = area[cd["wrinkle_state"][: len(tri)] == state].sum() / area.sum()
            assert fraction == pytest.approx(row[output], rel=1e-12, abs=1e-15)
    assert rows["wrinkled_fraction"][-1] > 0.5, "the test must see wrinkles"


def test_cable_fields_match_the_csv_outputs(tmp_path):
    rows, _, _, series = solve_with_vtk("SlidingCable", tmp_path)
    for k, (_, vtu) in enumerate(series):
        reference, cells, pd, cd = read_both(vtu)
        points = reference + pd["displacement_m"]
        lines = cells["line"]
        ntri = len(cells.get("triangle", []))
        row = rows[k]
        cable = lines_of(cd, 0)
        assert len(cable) == 4
        segs = lines[cable - ntri]
        for s, name in enumerate(["T_A7", "T_78", "T_89", "T_9B"]):
            assert cd["cable_tension_N"][cable[s]] == row[name], name
        # Sleeve points 7, 8, 9 are the ends of segments 0, 1, 2: cable_slip there is the probe.
        for s, name in enumerate(["slip7", "slip8", "slip9"]):
            assert pd["cable_slip_m"][segs[s, 1]] == row[name], name
        # A segment's slip (material that flowed in) is s_end - s_start = -slip[end] + slip[start].
        slip = pd["cable_slip_m"]
        assert np.allclose(cd["slip_m"][cable], slip[segs[:, 0]] - slip[segs[:, 1]], rtol=0, atol=1e-15)
        length = np.linalg.norm(points[segs[:, 1]] - points[segs[:, 0]], axis=1)
        assert length.sum() == pytest.approx(row["cable_length"], rel=1e-12)
        assert length[1:3].sum() == pytest.approx(row["span_7_9"], rel=1e-12)
        axis = (points[segs[:, 1]] - points[segs[:, 0]]) / length[:, None]
        assert np.allclose(cd["tension_direction"][cable], axis, rtol=0, atol=1e-15)
        assert np.all(np.isnan(cd["sigma_max_Pa"][cable])) and np.all(cd["wrinkle_state"][cable] == -1)
    assert abs(rows["slip7"][-1]) > 1e-3, "the test must see slip"


def test_sleeve_in_a_sheet(tmp_path):
    rows, elements, _, series = solve_with_vtk("SleeveCable", tmp_path)
    for k, (time, vtu) in enumerate(series):
        reference, cells, pd, cd = read_both(vtu)
        points = reference + pd["displacement_m"]
        lines = cells["line"]
        ntri = len(cells["triangle"])
        cable = lines_of(cd, 0)
        segs = lines[cable - ntri]
        row = rows[k]
        assert cd["cable_tension_N"][cable[0]] == row["tension_start"]
        assert cd["cable_tension_N"][cable[8]] == row["tension_end"]
        # The last sleeve point is where segment 8 starts (the cable leaves the sleeve at A).
        assert pd["cable_slip_m"][segs[8, 0]] == row["end_slip"]
        length = np.linalg.norm(points[segs[:, 1]] - points[segs[:, 0]], axis=1)
        assert length.sum() == pytest.approx(row["cable_length"], rel=1e-12)
        e = elements[elements["time"] == time]
        assert np.array_equal(np.sort(cd["sigma_max_Pa"][:ntri]), np.sort(e["sigma_max"]))
    assert rows["end_slip"][-1] != 0.0


def test_a_headless_screenshot(tmp_path):
    """pyvista renders a series off screen (what harness/main.sh does for its plots)."""
    import screenshot

    _, _, pvd, _ = solve_with_vtk("WrinkledShear", tmp_path)
    png = screenshot.screenshot(pvd, tmp_path / "shot.png")
    image = pyvista.read(png)
    pixels = np.asarray(image.point_data.active_scalars)
    assert image.dimensions[0] >= 1000
    assert len(np.unique(pixels.reshape(len(pixels), -1), axis=0)) > 10, "the picture is not blank"
