"""Running your own scene (issue 29 point 5; docs/harness.md, "Running your own scene"):
`python -m velarium.run` / `harness/run_main.py` with a load table, the load-response plot
against the input that varies, and the 3-D picture (velarium.render).

- A load table given with --loads is what the FMU carries, row by row (each recorded row's
  load equals the table's row before it, the one-step lag), and an input the table does not
  name keeps its start value.
- The x-axis: AnnulusTorsion's ramp holds two of its three inputs at their start values (the
  prestrain) and turns the hub: the plot is against hub_angle, not the first input; with two
  inputs varying it is against time.
- The scale factor: 1 when the largest displacement is at least 5 % of the span, else the
  1-2-5 number at most 0.1 span / largest displacement (exact values, computed by hand here).
- Both sheets: two stacked squares cover their plan twice and are cut open; one sheet is not.
  The picture of a synthetic two-sheet cushion is drawn cut, its stress bar in kPa.
"""

from __future__ import annotations

import numpy as np
import pytest

import velarium_run as vr


def test_a_load_table_is_what_the_rows_carry(tmp_path, velarium, capsys):
    from velarium import as_table
    from velarium.run import run_any

    loads = tmp_path / "loads.csv"
    loads.write_text("time,P\n0,0\n0.5,2500\n1,5000\n")
    out = run_any(vr.SCENES / "PrestressedCable" / "scene.json", tmp_path / "run", tmp_path / "fmus", loads=loads)
    for name in ("PrestressedCable.png", "PrestressedCable_3d.png", "vtk/PrestressedCable.pvd"):
        assert (out / name).stat().st_size > 0, name
    printed = capsys.readouterr().out
    header = next(line for line in printed.splitlines() if line.strip().startswith("time"))
    column = [t for t in header.split() if not t.startswith("[")].index("midspan_uz")
    table = [line.split() for line in printed.splitlines()[printed.splitlines().index(header) + 1:][:4]]
    carried = [float(r[1]) for r in table]
    assert carried == [0, 0, 2500, 5000]  # t = 0, then each row one step late
    solved = vr.solve(vr.SCENES / "PrestressedCable" / "scene.json", as_table({"time": [0, 1, 2], "P": [0, 2500, 5000]}), tmp_path)
    # The table prints 6 significant digits.
    assert np.allclose([float(r[column]) for r in table], [0.0] + list(solved["midspan_uz"]), rtol=1e-5, atol=0)
    assert "against P" in printed


def test_an_unknown_load_column_is_named(tmp_path, velarium):
    from velarium.run import run_any

    loads = tmp_path / "loads.csv"
    loads.write_text("time,Q\n0,0\n1,1\n")
    with pytest.raises(ValueError, match=r"loads\.Q: PrestressedCable has no input 'Q'"):
        run_any(vr.SCENES / "PrestressedCable" / "scene.json", tmp_path / "run", tmp_path / "fmus", loads=loads)


def test_the_plot_is_against_the_input_that_varies(tmp_path, velarium):
    import fmpy

    from velarium.run import load_table, varying_inputs

    fmu = vr.fmu_for(vr.SCENES / "AnnulusTorsion" / "scene.json", tmp_path)
    md = fmpy.read_model_description(str(fmu))
    ramp = vr.extend_by_one_step(vr.ramp_table(md, 4))
    assert [v.name for v in vr.inputs(md)][0] == "hub_radial"  # the first input, constant
    assert varying_inputs(ramp, md) == ["hub_angle"]
    table = load_table({"time": [0, 1, 2], "hub_angle": [0, 1e-3, 2e-3], "rim_radial": [3e-5, 2e-5, 1e-5]}, md)
    assert np.all(table["hub_radial"] == 1e-5)  # not in the table: its start value
    assert varying_inputs(vr.extend_by_one_step(table), md) == ["rim_radial", "hub_angle"]


def test_scale_factor_and_units():
    from velarium.render import scale_factor, stress_unit

    span = np.array([[0, 0, 0], [10, 0, 0], [0, 4, 0]], float)
    u = np.zeros((3, 3))
    u[1, 2] = 0.1  # 1 % of the span: 0.1 * 10 / 0.1 = 10
    assert scale_factor(u, span) == 10
    u[1, 2] = 0.3  # 3 %: wanted 3.33, the 1-2-5 number below it is 2
    assert scale_factor(u, span) == 2
    u[1, 2] = 0.6  # 6 %: true to scale
    assert scale_factor(u, span) == 1
    assert stress_unit(np.array([2e6, 3e5])) == ("MPa", 1e6)
    assert stress_unit(np.array([4e3, -1e3])) == ("kPa", 1e3)


def two_sheets(n: int = 6, gap: float = 0.4):
    """A square cushion of two sheets (z = 0 and z = gap), n x n cells each."""
    xs = np.linspace(0, 2, n + 1)
    grid = np.array([[x, y] for y in xs for x in xs])
    cells = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            cells += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    cells = np.array(cells)
    points = np.vstack([np.c_[grid, np.zeros(len(grid))], np.c_[grid, np.full(len(grid), gap)]])
    return points, np.vstack([cells, cells + len(grid)]), cells


def test_two_sheets_are_cut_open_and_one_is_not():
    from velarium.render import covers_plan_twice

    points, both, one = two_sheets()
    assert covers_plan_twice(points, both)
    assert not covers_plan_twice(points, one)


def test_the_cushion_picture_is_cut_and_in_kpa(tmp_path):
    pyvista = pytest.importorskip("pyvista")
    from velarium.render import picture

    points, tris, _ = two_sheets()
    cells = np.hstack([np.full((len(tris), 1), 3), tris]).ravel()
    grid = pyvista.UnstructuredGrid(cells, np.full(len(tris), 5, dtype=np.uint8), points)
    u = np.zeros_like(points)
    u[:, 2] = 0.01 * np.where(points[:, 2] > 0, 1, -1) * np.sin(np.pi * points[:, 0] / 2) * np.sin(np.pi * points[:, 1] / 2)
    grid.point_data["displacement_m"] = u
    grid.cell_data["kind"] = np.zeros(len(tris), dtype=np.int32)
    grid.cell_data["wrinkle_state"] = np.zeros(len(tris), dtype=np.int32)
    grid.cell_data["sigma_max_Pa"] = np.linspace(2e3, 9e3, len(tris))
    vtu = tmp_path / "cushion.vtu"
    grid.save(vtu)
    drawn = picture(vtu, tmp_path / "cushion.png", "two sheets")
    assert drawn["cut"] is True
    assert drawn["units"]["sigma_max_Pa"] == "kPa"
    assert drawn["scale"] == 20  # largest 0.01 m on a 2 m span: 0.1 * 2 / 0.01 = 20
