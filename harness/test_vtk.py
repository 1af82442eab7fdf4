"""The ParaView series of `velarium solve --vtk DIR` read back by two independent readers
(meshio, pyvista) and checked field by field against `velarium solve`'s own CSV outputs and its
--elements CSV of the same run. Every comparison is exact (both sides are the same f64 written
in shortest round-trip form) unless a tolerance is given: quantities the test recomputes from
the written points (lengths, areas, fractions) agree to 1e-12 relative.

Scenes: WrinkledShear (2400 triangles, taut/wrinkled states, reactions), SlidingCable (cables
through a frictionless sleeve: per-segment tensions and slips), SleeveCable (rubber sheet with a
cable in a sleeve: tensions, end slip, lengths).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import meshio
import numpy as np
import pytest

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


def cell_fields(mesh: meshio.Mesh) -> dict[str, np.ndarray]:
    """meshio's per-block cell data joined in cell order (triangles, then lines)."""
    return {name: np.concatenate([np.asarray(d).reshape(len(d), -1).squeeze() if np.asarray(d).ndim > 1 and np.asarray(d).shape[1] == 1 else np.asarray(d) for d in blocks]) for name, blocks in mesh.cell_data.items()}


def read_both(vtu: Path):
    """(points, cells by type, point data, cell data) from meshio, checked equal to pyvista's."""
    m = meshio.read(vtu)
    cells = {b.type: b.data for b in m.cells}
    cd = cell_fields(m)
    g = pyvista.read(vtu)
    assert np.array_equal(g.points, m.points)
    assert g.n_cells == sum(len(c) for c in cells.values())
    for name, values in cd.items():
        assert np.array_equal(np.asarray(g.cell_data[name]).reshape(values.shape), values, equal_nan=True), name
    for name, values in m.point_data.items():
        assert np.array_equal(np.asarray(g.point_data[name]).reshape(np.shape(values)), values), name
    pd = {name: np.asarray(v)[:, 0] if np.ndim(v) == 2 and np.shape(v)[1] == 1 else np.asarray(v) for name, v in m.point_data.items()}
    return m.points, cells, pd, cd


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
    assert np.array_equal(last.points, meshio.read(series[-1][1]).points)


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
        # Vertices (current positions), state, principal stresses, tension direction.
        for v in range(3):
            assert np.array_equal(points[tri[order, v]], np.column_stack([e[f"x{v + 1}"], e[f"y{v + 1}"], e[f"z{v + 1}"]]))
        assert np.array_equal(cd["wrinkle_state"][order], e["state"].astype(int))
        assert np.array_equal(cd["sigma_max"][order], e["sigma_max"])
        assert np.array_equal(cd["sigma_min"][order], e["sigma_min"])
        assert np.array_equal(cd["tension_direction"][order], np.column_stack([e["tension_x"], e["tension_y"], e["tension_z"]]))
        # The reference configuration (points - displacement) does not change from row to row.
        ref = points - pd["displacement"]
        if reference is None:
            reference = ref
        assert np.allclose(ref, reference, rtol=0, atol=1e-15)
        # The CSV outputs of the same row.
        row = rows[k]
        assert np.max(cd["sigma_max"][: len(tri)]) == row["max_principal_stress"]
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
        points, cells, pd, cd = read_both(vtu)
        lines = cells["line"]
        ntri = len(cells.get("triangle", []))
        row = rows[k]
        cable = lines_of(cd, 0)
        assert len(cable) == 4
        segs = lines[cable - ntri]
        for s, name in enumerate(["T_A7", "T_78", "T_89", "T_9B"]):
            assert cd["cable_tension"][cable[s]] == row[name], name
        # Sleeve points 7, 8, 9 are the ends of segments 0, 1, 2: cable_slip there is the probe.
        for s, name in enumerate(["slip7", "slip8", "slip9"]):
            assert pd["cable_slip"][segs[s, 1]] == row[name], name
        # A segment's slip (material that flowed in) is s_end - s_start = -slip[end] + slip[start].
        slip = pd["cable_slip"]
        assert np.allclose(cd["slip"][cable], slip[segs[:, 0]] - slip[segs[:, 1]], rtol=0, atol=1e-15)
        length = np.linalg.norm(points[segs[:, 1]] - points[segs[:, 0]], axis=1)
        assert length.sum() == pytest.approx(row["cable_length"], rel=1e-12)
        assert length[1:3].sum() == pytest.approx(row["span_7_9"], rel=1e-12)
        axis = (points[segs[:, 1]] - points[segs[:, 0]]) / length[:, None]
        assert np.allclose(cd["tension_direction"][cable], axis, rtol=0, atol=1e-15)
        assert np.all(np.isnan(cd["sigma_max"][cable])) and np.all(cd["wrinkle_state"][cable] == -1)
    assert abs(rows["slip7"][-1]) > 1e-3, "the test must see slip"


def test_sleeve_in_a_sheet(tmp_path):
    rows, elements, _, series = solve_with_vtk("SleeveCable", tmp_path)
    for k, (time, vtu) in enumerate(series):
        points, cells, pd, cd = read_both(vtu)
        lines = cells["line"]
        ntri = len(cells["triangle"])
        cable = lines_of(cd, 0)
        segs = lines[cable - ntri]
        row = rows[k]
        assert cd["cable_tension"][cable[0]] == row["tension_start"]
        assert cd["cable_tension"][cable[8]] == row["tension_end"]
        # The last sleeve point is where segment 8 starts (the cable leaves the sleeve at A).
        assert pd["cable_slip"][segs[8, 0]] == row["end_slip"]
        length = np.linalg.norm(points[segs[:, 1]] - points[segs[:, 0]], axis=1)
        assert length.sum() == pytest.approx(row["cable_length"], rel=1e-12)
        e = elements[elements["time"] == time]
        assert np.array_equal(np.sort(cd["sigma_max"][:ntri]), np.sort(e["sigma_max"]))
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
