"""The cushion-and-blower system with the cushion's mass (docs/coupling.md, "The dynamic
system"): the example's cushion scenes made dynamic (velarium.couple_dynamic: foil density
1750 kg/m³, Rayleigh α 20/s, generalized-α ρ∞ 0.9), a snow load 0 -> 200 Pa between 0.02 and
0.03 s, 0.04 s in macro steps of 0.01 s.

References and tolerances:

- The dynamic monolithic answer (couple_monolithic.solve on the dynamic `gas` scene, started
  from the quasi-static scene's equilibrium at 200 Pa, the blower's balance solved around the
  scene to round-off; no code shared with the master or the Blower FMU) at the same macro step:
  the coupled Newton answer is converged to an interface residual of 1e-10 and differs from it
  by 6.4e-13 relative in p and 9e-15 in V and N (measured over 0.1 s); tolerance 1e-9: ten
  times the interface tolerance (the bound the convergence test sets), as in the quasi-static
  system's test.
- Velarium refuses directional derivatives of dynamic scenes (an Error naming
  time_integration): the master's Newton says so once and takes the cushion's interface
  Jacobian by finite differences of steps from the saved states (Master.notes).
- Plain Gauss-Seidel contracts the interface residual by the loop gain J_B J_A (the blower's
  derivative times the cushion's step's finite difference): at h = 0.01 s the gain is about
  -10 (the gas stiffer than the cushion's inertia-limited compliance), so every attempt is
  rolled back and halved, then an error; at h = 0.5 ms the cushion's inertia keeps the gain at
  -0.1689 and the median ratio of successive residuals equals |gain| (measured 9.5e-5
  relative: the forward difference's truncation); tolerance 1e-3.
"""

from __future__ import annotations

import numpy as np
import pytest

from test_coupling import blower_fmu  # noqa: F401  (the session fixture that packs harness/blower/)

couple = pytest.importorskip("velarium.couple")
couple_dynamic = pytest.importorskip("velarium.couple_dynamic")
study = pytest.importorskip("coupling_dynamic_study")

import velarium_run as vr  # noqa: E402


@pytest.fixture(scope="module")
def dyn(blower_fmu, tmp_path_factory):  # noqa: F811
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    return study.system(tmp_path_factory.mktemp("coupling_dynamic"), blower_fmu, stop=0.04)


def test_dynamic_newton_agrees_with_the_dynamic_monolithic_answer(dyn, capfd):
    ref = couple_dynamic.monolithic(dyn, 0.01)
    m = couple.Master(dyn["fmu_paths"], dyn["connections"], dyn.get("inputs"),
                      {n: s.get("start", {}) for n, s in dyn["fmus"].items()})
    with m:
        r = m.run(0.04, 0.01, "newton", record=list(dyn["monolithic"]["compare"]))
        notes = list(m.notes)
    assert r.rejected == []
    assert len(notes) == 1 and "cushion: directional derivatives refused" in notes[0]
    assert "finite differences" in capfd.readouterr().err
    d = couple.difference(r, ref, dyn["monolithic"]["compare"])
    print("iterations", r.iterations[1:].tolist(), "difference", d)
    assert all(v < 1e-9 for v in d.values()), d
    assert r.iterations[1:].max() <= 6
    # the snow moved the structure: not the initial equilibrium
    assert abs(ref["p"][-1] - ref["p"][0]) > 10.0


def test_gauss_seidel_fails_where_the_dynamic_loop_gain_passes_one(dyn):
    (h_small, ja_s, jb_s), (h_mid, ja_m, jb_m) = study.loop_gain(dyn, (5e-4, 0.01))
    assert abs(ja_m * jb_m) > 5.0 and abs(ja_s * jb_s) < 0.5
    one = dict(dyn, stop=h_small)
    r = couple.run_system(one, "gs", h_small, max_iterations=60, min_step=h_small)
    hist = np.array(r.records[1].history)
    ratio = np.median(hist[1:6] / hist[:5])
    assert ratio == pytest.approx(abs(ja_s * jb_s), rel=1e-3)
    one = dict(dyn, stop=h_mid)
    m = couple.Master(one["fmu_paths"], one["connections"], one.get("inputs"),
                      {n: s.get("start", {}) for n, s in one["fmus"].items()})
    with m:
        with pytest.raises(couple.CouplingError, match="no macro step down to"):
            m.run(h_mid, h_mid, "gs", max_iterations=30, min_step=h_mid / 2)
        assert [round(h, 6) for _, h, _, _ in m.rejected] == [0.01, 0.005]
