"""The README's worked example ("Your own scene"): examples/WindSquare.json, a flat 4 m square
membrane (32 x 32 cells) with four edge cables, held at its corners, under wind pressure
ramped 0 -> 300 Pa. The two documented commands run as written (output directories moved
into a temporary directory):

    target/release/velarium solve examples/WindSquare.json --loads examples/WindSquare-loads.csv \\
        --out build/WindSquare/solve.csv --vtk build/WindSquare/vtk
    .venv/bin/python harness/run_main.py examples/WindSquare.json

The first gives a ParaView series of 11 rows, the second the table through the FMU, the
load-response plot, the 3-D plot and its own series. Checks: every row converges; the FMU's
row at t_{k+1} equals solve's row k exactly (the one-step lag; the extended table makes the last
FMU row carry 300 Pa); positive pressure lifts the sheet (+z, the counter-clockwise normal of the
generated mesh); vertical equilibrium of the deformed sheet: the follower pressure's resultant
is p times the area of the deformed surface projected on x-y (computed here from the .vtu
points), carried by the four corners (equal by symmetry): 4 x corner reaction = -p x A_xy to
1e-8 relative (measured 9e-10; the solver's tolerance is 1e-9 of the largest force).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import velarium_run as vr

SCENE = vr.ROOT / "examples" / "WindSquare.json"
LOADS = vr.ROOT / "examples" / "WindSquare-loads.csv"


def test_json_to_paraview_and_3d_plot_in_two_commands(tmp_path):
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    first = subprocess.run(
        [str(vr.VELARIUM), "solve", str(SCENE), "--loads", str(LOADS), "--out", str(tmp_path / "WindSquare" / "solve.csv"),
         "--vtk", str(tmp_path / "WindSquare" / "vtk")],
        capture_output=True, text=True, timeout=600,
    )
    assert first.returncode == 0, first.stderr
    solved = vr.read_csv(tmp_path / "WindSquare" / "solve.csv")
    series = vr.series_files(tmp_path / "WindSquare" / "vtk" / "WindSquare.pvd")
    assert len(solved) == len(series) == 11
    assert all(p.is_file() for _, p in series)

    out = tmp_path / "run"
    second = subprocess.run(
        [sys.executable, str(vr.ROOT / "harness" / "run_main.py"), str(SCENE), "--out", str(out)],
        capture_output=True, text=True, timeout=900, cwd=vr.ROOT,
    )
    assert second.returncode == 0, second.stdout + second.stderr
    for name in ("WindSquare.png", "WindSquare_3d.png", "vtk/WindSquare.pvd", "vtk/WindSquare_0010.vtu"):
        assert (out / name).stat().st_size > 0, name
    assert "wrote" in second.stdout and "center_uz" in second.stdout

    # The FMU run (fmpy) against solve: row k of solve is fmpy's row at t_{k+1}.
    fmu = vr.FMU_DIR / "WindSquare.fmu"
    md = vr.fmpy.read_model_description(str(fmu))
    table = vr.ramp_table(md, 10)
    assert list(table["wind"]) == list(np.genfromtxt(LOADS, delimiter=",", names=True)["wind"])
    rows = vr.simulate(fmu, vr.extend_by_one_step(table))
    for v in vr.outputs(md):
        assert list(map(float, rows[v.name][1:])) == list(solved[v.name]), v.name

    import fmu_vtk

    last = solved[-1]
    assert last["center_uz"] > 0.2
    mesh = fmu_vtk.read_vtu(series[-1][1])
    deformed = mesh.points + mesh.point_data["displacement_m"]  # the points are the reference
    tri = deformed[mesh.connectivity[: 3 * np.sum(mesh.types == 5)].reshape(-1, 3)]
    a, b = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    projected = 0.5 * np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    assert 15.0 < projected < 16.0, "the sheet pulls in a little"
    assert 4.0 * last["corner_reaction_z"] == pytest.approx(-300.0 * projected, rel=1e-8)
