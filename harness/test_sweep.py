"""harness/sweep.py: the same small sweep on Dask's synchronous scheduler and on a 2-worker local
cluster gives the same tidy table, bit for bit, and every run equals fmpy.simulate_fmu on the
same (extended) load table with the same start values: the sweep adds scheduling, not physics.
A run whose step returns Discard is kept, marked `discard`, with the rows before it.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest

import fmi_support as fs
import sweep
import velarium_run as vr

NAME = "PrestressedCable"
GRID = ["--grid", "P=2000,6000", "--grid", "EA=5e5,1e6", "--steps", "4"]


@pytest.fixture
def cable_fmu():
    path = vr.FMU_DIR / f"{NAME}.fmu"
    if not path.is_file():
        pytest.skip(f"{path} is missing: run `bash .ci/run`")
    return path


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_synchronous_and_two_workers_agree_and_match_simulate_fmu(cable_fmu, tmp_path):
    one = sweep.main([str(cable_fmu), *GRID, "--scheduler", "synchronous", "--out", str(tmp_path / "sync")])
    two = sweep.main([str(cable_fmu), *GRID, "--scheduler", "local", "--workers", "2", "--out", str(tmp_path / "local")])
    assert one["runs"] == two["runs"] == 4
    assert (tmp_path / "sync" / "sweep.csv").read_bytes() == (tmp_path / "local" / "sweep.csv").read_bytes()
    assert (tmp_path / "local" / "sweep.png").stat().st_size > 0
    rows = read(tmp_path / "sync" / "sweep.csv")
    assert list(rows[0])[:6] == ["run", "P_target", "EA", "status", "time", "P"]
    md = vr.fmpy.read_model_description(str(cable_fmu))
    for run in range(4):
        mine = [r for r in rows if int(r["run"]) == run]
        assert all(r["status"] == "ok" for r in mine)
        target, ea = float(mine[0]["P_target"]), float(mine[0]["EA"])
        table = vr.ramp_table(md, 4)
        table["P"] = np.linspace(0.0, target, 5)
        extended = vr.extend_by_one_step(table)
        ref = vr.simulate(cable_fmu, extended, start_values={"EA": ea})
        assert len(ref) == len(mine) == 6
        for name in ["time"] + [v.name for v in vr.outputs(md)]:
            assert [float(r[name]) for r in mine] == list(map(float, ref[name])), name
        # The last row carries the ramp's last value (the extension by one step).
        assert float(mine[-1]["P"]) == target


def test_a_discarded_run_is_kept_and_marked(tmp_path):
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing")
    fmu = fs.debug_variant(NAME, tmp_path / "variant", vr.VELARIUM, fail_after_time=0.55)
    result = sweep.main([str(fmu), "--grid", "debug_fail_after_time=0.55,5", "--steps", "4", "--scheduler", "synchronous",
                         "--out", str(tmp_path / "out")])
    rows = read(tmp_path / "out" / "sweep.csv")
    failed = [r for r in rows if float(r["debug_fail_after_time"]) == 0.55]
    fine = [r for r in rows if float(r["debug_fail_after_time"]) == 5]
    assert {r["status"] for r in failed} == {"discard"} and {r["status"] for r in fine} == {"ok"}
    # Steps end at 0.25, 0.5, 0.75: the one ending at 0.75 > 0.55 fails; rows at 0, 0.25, 0.5 stay.
    assert [float(r["time"]) for r in failed] == [0.0, 0.25, 0.5]
    assert len(fine) == 6
    assert result["runs"] == 2
