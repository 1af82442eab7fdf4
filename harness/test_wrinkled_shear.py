"""The WrinkledShear script of the main job (harness/wrinkled_shear.py) through fmpy: the film
shears to 3 mm, wrinkles at the onset shear (docs/mechanics.md §4c: 1.565 mm for 1 mm separation on a
128 mm wide film), and the plots are written."""

from __future__ import annotations

import numpy as np
import pytest

import velarium_run as vr
import wrinkled_shear as ws


@pytest.fixture(scope="module")
def history():
    fmu = vr.FMU_DIR / f"{ws.NAME}.fmu"
    if not fmu.is_file():
        pytest.fail(f"{fmu} missing: .ci/run packs every shipped scene before the harness runs")
    table = ws.shear_table(1e-3)
    return table, vr.simulate(fmu, table)


def test_centre_wrinkles_at_the_onset_shear(history):
    table, rows = history
    carried = np.concatenate([table["shear"][:1], table["shear"][:-1]])
    state = rows["center_state"]
    onset = 2 * np.sqrt(0.3) / 0.7 * 1e-3  # γ_c H = 2√ν ε0 H / (1 − ν)
    assert np.all(state[carried < 0.95 * onset] == 0), "taut below the onset"
    assert np.all(state[carried > 1.05 * onset] == 1), "wrinkled above the onset"
    assert rows["wrinkled_fraction"][-1] > 0.9


def test_script_prints_and_plots(capsys):
    assert ws.main() == 0
    out = capsys.readouterr().out
    assert "Newton iterations per shear step: median" in out
    for name in (f"{ws.NAME}.png", f"{ws.NAME}_elements.png"):
        assert (ws.PLOTS / name).stat().st_size > 10_000, name
