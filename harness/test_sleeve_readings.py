"""The second reading of seed Fig. 1 (SleeveDrawstring, examples/SleeveDrawstring.json, packed
here into build/fmus/) through its FMU, and the Table 1 RMS that
harness/sleeve_readings.py reports, recomputed by hand.

Claims checked (docs/mechanics.md §7, measured with the scene's start values mu_rubber 3e5 Pa,
mu_friction 0.3):
- on 2P = 0, 0.05, 0.10, 0.15 N the drawstring gathers its sleeved edge: L_c falls below its
  unloaded 0.080 m and keeps falling, A moves down (A_dy < 0, decreasing) and B up by the same
  amount (mirror symmetry of the scene about mid-height: A_dy = -B_dy to 1e-6 relative);
- on Table 1's path (2P = 0, 1, 2, 4, 5 N, one step each) the FMU discards the step to 2P = 1 N
  (the open solver problem of §7): the run ends with the 2P = 0 row and a Discard message, not
  a crash and not a silent wrong answer;
- the RMS that sleeve_readings prints for SleeveCable at its calibrated pair (1.089e5 Pa, 1.5)
  equals the RMS recomputed from seed_table1.csv read with the csv module (1e-12 mm) and is the
  4.94 mm that docs/mechanics.md §7 states (to 0.01 mm).
"""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

import sleeve_readings as sr
import sleeve_table as st
import velarium_run as vr


def fmu_or_skip(name: str):
    if name == "SleeveDrawstring":  # not shipped yet: pack examples/SleeveDrawstring.json here
        if not vr.VELARIUM.is_file():
            pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
        sr.pack_drawstring()
    path = vr.FMU_DIR / f"{name}.fmu"
    if not path.is_file():
        pytest.skip(f"{path} is missing: run `bash .ci/run` (or velarium pack modelDescription/{name}/scene.json --out build/fmus)")


def test_drawstring_gathers_its_edge_symmetrically():
    fmu_or_skip("SleeveDrawstring")
    rows, message = sr.stopped("SleeveDrawstring", 3e5, 0.3, np.array([0.0, 0.05, 0.10, 0.15]))
    assert message == "" and len(rows) == 4, "all four rows converge"
    assert rows["L_c"][0] == pytest.approx(0.080, abs=1e-12)
    assert np.all(np.diff(rows["L_c"]) < 0) and rows["L_c"][-1] < 0.080
    assert np.all(np.diff(rows["A_dy"]) < 0)
    assert np.all(np.abs(rows["A_dy"][1:] + rows["B_dy"][1:]) <= 1e-6 * np.abs(rows["B_dy"][1:]))
    assert np.all(rows["A_dx"][1:] > 0)


def test_drawstring_table1_path_is_discarded_at_1N():
    fmu_or_skip("SleeveDrawstring")
    exp = st.experiment()
    rows, message = sr.stopped("SleeveDrawstring", 3e5, 0.3, np.asarray(exp["force_2P_N"], dtype=float))
    assert len(rows) == 1, "only the 2P = 0 row converges"
    assert "did not converge" in message


def test_reported_rms_matches_a_recomputation():
    fmu_or_skip("SleeveCable")
    exp = st.experiment()
    loads = np.asarray(exp["force_2P_N"], dtype=float)
    rows, message = sr.stopped("SleeveCable", 1.089e5, 1.5, loads)
    assert message == "" and len(rows) == len(loads), "all Table 1 rows converge"
    table = [r for r in csv.DictReader(line for line in st.TABLE.read_text().splitlines() if line and not line.startswith("#"))]
    columns = {"A_dx": "node_A_dx_m", "A_dy": "node_A_dy_m", "B_dy": "node_B_dy_m", "L_c": "cable_length_m"}
    squares = []
    for k in range(1, len(table)):
        for ours, col in columns.items():
            squares.append((1e3 * (float(rows[ours][k]) - float(table[k][col]))) ** 2)
    by_hand = math.sqrt(sum(squares) / len(squares))
    assert sr.rms_overall(exp, rows) == pytest.approx(by_hand, abs=1e-12)
    assert by_hand == pytest.approx(4.94, abs=0.01)
    per = sr.rms_per_column(exp, rows)
    assert math.sqrt(sum(v ** 2 for v in per.values()) / 4) == pytest.approx(by_hand, abs=1e-12)
    assert not sr.sign_change(rows["A_dy"]) and sr.sign_change(exp["node_A_dy_m"])
    assert sr.s_shape(loads, exp["node_A_dx_m"]) and not sr.s_shape(loads, rows["A_dx"])
