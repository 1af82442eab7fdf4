"""Speed against error (harness/speed_error.py; docs/harness.md, "Speed against error"): the
plot's data path without the peer, on the three smallest meshes of each case (about a second).

REFERENCE: docs/mechanics.md §4a (Hencky disc, follower pressure, exact kinematics, qa/(Eh) =
1e-3: w0/a = 0.065404) and §4b (wrinkled annulus, rho = 4: L/a = 1.80566 at tau = 3, the
documented value the closed form's wrinkled radius must give; the inner rim's displacement is the
tension field inside L plus Lamé outside, small strain).
TOLERANCES: the errors must fall with the mesh (each refinement at least halves them: measured
ratios 3.6-4.0), and stay within 1.5x of what these meshes reach (Hencky 8, 16, 32 rings:
2.63e-3, 7.26e-4, 2.01e-4; annulus 9x24, 18x48, 36x96: 3.48e-2, 8.62e-3, 2.19e-3; measured with
`.venv/bin/python harness/speed_error.py --no-peer`, 2026-11-28).
Without the peer the title says the plot is ours alone.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

import speed_error as se


def test_the_annulus_closed_form_wrinkles_where_the_docs_say():
    rho, tau = se.LAME_B / se.LAME_A, se.LAME_TAU
    big_l = (rho**2 / tau) * (1 - math.sqrt(1 - tau**2 / rho**2))
    assert abs(big_l - 1.80566) < 5e-6
    with pytest.raises(ValueError, match="outside the wrinkled range"):
        se.lame_reference(tau=1.5)
    # Without the wrinkled zone's stretch the rim would move only by Poisson's contraction at L.
    assert se.lame_reference() < -se.LAME_NU * tau * se.LAME_SIGMA_OUT * se.LAME_A / se.LAME_E


def test_ours_alone_on_small_meshes(tmp_path, velarium, monkeypatch):
    monkeypatch.setenv("KRATOS_PYTHON", str(tmp_path / "no-such-python"))
    out = tmp_path / "speed_error.png"
    points = se.main(["--quick", "--no-peer", "--out", str(out), "--velarium", str(velarium)])
    assert out.stat().st_size > 0
    with open(out.with_suffix(".csv")) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(points) == 6
    assert {r["solver"] for r in rows} == {"velarium"}
    measured = {"hencky": [2.63e-3, 7.26e-4, 2.01e-4], "lame": [3.48e-2, 8.62e-3, 2.19e-3]}
    for case, reached in measured.items():
        errors = [p.error for p in points if p.case == case]
        assert all(e < 1.5 * r for e, r in zip(errors, reached)), (case, errors)
        assert all(b < a / 2 for a, b in zip(errors, errors[1:])), (case, errors)
        assert all(p.seconds > 0 for p in points if p.case == case)


def test_the_title_says_when_the_peer_is_missing(tmp_path):
    reason = se.peer_available(tmp_path / "no-such-python")
    assert reason is not None and "is missing" in reason
    point = se.Point("hencky", "velarium", "8 rings", 507, 0.01, 0.0328, 0.0327, 2.6e-3)
    import matplotlib

    matplotlib.use("Agg")
    captured = {}
    import matplotlib.figure

    original = matplotlib.figure.Figure.suptitle

    def spy(self, text, *a, **k):
        captured["title"] = text
        return original(self, text, *a, **k)

    matplotlib.figure.Figure.suptitle = spy
    try:
        se.plot([point], tmp_path / "p.png", reason)
    finally:
        matplotlib.figure.Figure.suptitle = original
    assert captured["title"].startswith("Speed against error: Velarium alone (no peer:")
    assert Path(tmp_path / "p.png").stat().st_size > 0


def test_the_peer_agrees_on_the_identical_mesh(tmp_path, velarium):
    """With the optional peer installed (skipped otherwise, as in CI): the smallest annulus,
    9x24, through both codes on the same mesh gives the same inner rim displacement to 1e-6
    relative (measured 4e-7), about 3 s."""
    import json
    import os
    import subprocess

    reason = se.peer_available()
    if reason is not None:
        pytest.skip(f"the peer is not installed: {reason}")
    scene = se.lame_scene(9, 24)
    out, _ = se.solve_once(scene, se.lame_loads(), tmp_path, velarium, vtk=tmp_path / "vtk")
    se.export_mesh(scene, tmp_path / "vtk", tmp_path / "mesh.npz")
    run = subprocess.run([str(se.KRATOS_PYTHON), str(se.HERE / "peer_kratos.py"), "lame", str(tmp_path / "mesh.npz")],
                         capture_output=True, text=True, env=dict(os.environ, OMP_NUM_THREADS="1"), timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    peer = json.loads(next(line for line in reversed(run.stdout.splitlines()) if line.startswith("{")))
    assert abs(peer["value"] - out["u_in"]) < 1e-6 * abs(out["u_in"]), (peer, out)
