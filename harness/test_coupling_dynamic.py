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
- Velarium gives the derivatives of a dynamic scene's step (the change of the outputs at the
  end of the last doStep with the inputs set before it, the step's start state held;
  docs/dynamics.md): the master's Newton takes the cushion's interface Jacobian from
  GetDirectionalDerivative, no note, one cushion step per iteration (the finite-difference
  Jacobian took one more per Newton iteration). Over 0.04 s at h = 0.01 s: 4-6 iterations per
  macro step (the same as with the difference Jacobian, whose error was already small), 0.1 s
  measured in harness/coupling_dynamic_study.py.
- The FMU's derivative itself, FMI 2 and FMI 3, against a central difference of the cushion's
  step from its saved state (δ = 0.01 Pa of p and of snow, the scene's solver tolerance
  1e-12): measured 5.4e-11 (dV/dp) and 2.6e-11 (dV/dsnow) relative, the same bits in both
  versions; tolerance 5e-10. FMI 3's adjoint equals its directional derivatives to 1e-12
  (relative; measured equal to round-off).
- Plain Gauss-Seidel contracts the interface residual by the loop gain J_B J_A (the blower's
  derivative times the cushion's step derivative): at h = 0.01 s the gain is about
  -10 (the gas stiffer than the cushion's inertia-limited compliance), so every attempt is
  rolled back and halved, then an error; at h = 0.5 ms the cushion's inertia keeps the gain at
  -0.1689 and the median ratio of successive residuals equals |gain| (measured 9.5e-5
  relative, the same as with the forward difference of the step that gave the gain before the
  derivative existed, which is within 5.6e-7 of the derivative: so not the Jacobian's error
  but the gain's change over the iterates; the gain is taken at the step from t = 1e-4 s, the
  run's first step starts at 0); tolerance 1e-3.
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
        jacobians = m.units["cushion"].jacobians
    assert r.rejected == []
    # the cushion's own derivatives: no note, no extra step
    assert notes == [] and "refused" not in capfd.readouterr().err
    assert r.fmu_steps["cushion"] == r.fmu_steps["blower"] == int(r.iterations[1:].sum())
    assert jacobians == int((r.iterations[1:] - 1).sum())
    d = couple.difference(r, ref, dyn["monolithic"]["compare"])
    print("iterations", r.iterations[1:].tolist(), "difference", d)
    assert all(v < 1e-9 for v in d.values()), d
    assert r.iterations[1:].max() <= 6
    # the snow moved the structure: not the initial equilibrium
    assert abs(ref["p"][-1] - ref["p"][0]) > 10.0


@pytest.mark.parametrize("fmi", [2, 3])
def test_the_cushions_step_derivative_is_the_difference_of_its_step(blower_fmu, tmp_path, fmi):  # noqa: F811
    """dV/dp of the dynamic cushion's FMU after a step against a central difference of that
    step from its saved state (module docstring)."""
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    sysd = couple_dynamic.load_dynamic_system(study.SYSTEM, tmp_path, fmi=fmi)
    u = couple.Unit("cushion", sysd["fmu_paths"]["cushion"])
    try:
        u.initialize(0.0, {"p": 200.0, "snow": 0.0})
        h, t = 0.01, 0.0
        for p, snow in ((210.0, 0.0), (220.0, 50.0)):
            u.set({"p": p, "snow": snow})
            u.step(t, h)
            t += h
        state = u.save()
        u.set({"p": 230.0, "snow": 100.0})
        u.step(t, h)
        jac = u.jacobian(["V"], ["p", "snow"])
        if fmi == 3:
            # fmpy sizes the sensitivity by the unknowns unless told: one per known here
            w = u.slave.getAdjointDerivative([u.vr["V"]], [u.vr["p"], u.vr["snow"]], [1.0], nSensitivity=2)
            assert np.allclose(w, jac[0], rtol=1e-12, atol=0), (w, jac)
        delta = 0.01
        fd = []
        for name in ("p", "snow"):
            vals = []
            for sign in (1, -1):
                u.restore(state)
                x = {"p": 230.0, "snow": 100.0}
                x[name] += sign * delta
                u.set(x)
                u.step(t, h)
                vals.append(u.get(["V"])[0])
            fd.append((vals[0] - vals[1]) / (2 * delta))
        err = np.abs(jac[0] - fd) / np.max(np.abs(fd))
        print(f"FMI {fmi}: dV/d(p, snow) {jac[0]} against {fd}: {err}")
        assert np.all(err < 5e-10), err
        u.free_state(state)
    finally:
        u.close()


def test_gauss_seidel_fails_where_the_dynamic_loop_gain_passes_one(dyn):
    (h_small, ja_s, jb_s, fd_s), (h_mid, ja_m, jb_m, _) = study.loop_gain(dyn, (5e-4, 0.01))
    assert abs(ja_m * jb_m) > 5.0 and abs(ja_s * jb_s) < 0.5
    one = dict(dyn, stop=h_small)
    r = couple.run_system(one, "gs", h_small, max_iterations=60, min_step=h_small)
    hist = np.array(r.records[1].history)
    ratio = np.median(hist[1:6] / hist[:5])
    print("gain", ja_s * jb_s, "ratio", ratio, "rel", abs(ratio / abs(ja_s * jb_s) - 1), "fd", abs(fd_s / ja_s - 1))
    assert ratio == pytest.approx(abs(ja_s * jb_s), rel=1e-3)
    one = dict(dyn, stop=h_mid)
    m = couple.Master(one["fmu_paths"], one["connections"], one.get("inputs"),
                      {n: s.get("start", {}) for n, s in one["fmus"].items()})
    with m:
        with pytest.raises(couple.CouplingError, match="no macro step down to"):
            m.run(h_mid, h_mid, "gs", max_iterations=30, min_step=h_mid / 2)
        assert [round(h, 6) for _, h, _, _ in m.rejected] == [0.01, 0.005]
