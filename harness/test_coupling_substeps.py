"""Sub-steps inside the coupling's macro step (docs/coupling.md, "Sub-steps inside the macro
step"): why the coupled cushion and blower leave the monolithic answer and fail when the
cushion takes several sub-steps per macro step, in a one-degree-of-freedom model
(harness/coupling_substep_model.py) and on the real system.

References and tolerances:

- The model's sub-step is generalized-α (Chung & Hulbert 1993, J. Appl. Mech. 60:371-375): for
  an undamped oscillator its spectral radius tends to ρ∞ as ωΔt → ∞ and to 1 as ωΔt → 0 (both
  from that paper). Measured: 0.9 + 3.1e-4 at ωΔt = 1e5 (the approach is slow), tolerance 1e-3;
  1 − 2.2e-16 at ωΔt = 1e-3, tolerance 1e-12.
- With one sub-step the coupled scheme (the interface converged) and the monolithic one are the
  same discrete equations: their maps agree on states with p = −k_g u to 3.1e-10 relative (the
  coupled fixed point solved from an affine fit with k_g ≈ 2.2e6: round-off amplified),
  tolerance 1e-9.
- The model's spectral radius per macro step with four sub-steps: 2.25 for the coupled scheme
  (pressure linear over the sub-steps) at h = 10 ms, 0.99 at 1 ms and 0.90 at 20 ms; the
  monolithic scheme 0.97. The test asserts the side of 1, which is what the real system shows.
- The real system (the example with the cushion's mass, Newton with the FMUs' derivatives): it
  runs 0.2 s with no step rejected at h = 20 ms in sub-steps of 5 ms, where the model's radius
  is 0.90, and fails at h = 10 ms in sub-steps of 2.5 ms (radius 2.25), as measured before
  (0.080 s).
"""

from __future__ import annotations

import numpy as np
import pytest

from test_coupling import blower_fmu  # noqa: F401  (the session fixture that packs harness/blower/)

import coupling_substep_model as model

couple = pytest.importorskip("velarium.couple")
couple_dynamic = pytest.importorskip("velarium.couple_dynamic")
study = pytest.importorskip("coupling_dynamic_study")


def _substep_radius(omega_dt: float) -> float:
    a = np.column_stack([model.substep(e, omega_dt, 1.0, 0.0, 0.0, c=0.0) for e in np.eye(3)])
    return float(max(abs(np.linalg.eigvals(a))))


def test_the_models_substep_is_generalized_alpha():
    assert abs(_substep_radius(1e5) - model.RHO_INF) < 1e-3
    assert abs(_substep_radius(1e-3) - 1.0) < 1e-12


def test_one_substep_coupled_is_the_monolithic_scheme():
    worst = 0.0
    for h in (1e-3, 1e-2, 0.1):
        for s in ([1.0, 0.3, -5.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]):
            x = np.array(s + [-model.K_G * s[0]])
            a, b = model.linear(x, h, 1), model.monolithic(x, h, 1)
            worst = max(worst, float(np.max(np.abs(a - b)) / np.max(np.abs(b))))
    assert worst < 1e-9


def test_the_coupled_scheme_with_substeps_is_unstable_in_a_band_of_macro_steps():
    assert model.radius(model.monolithic, 1e-2, 4) < 1.0
    assert model.radius(model.linear, 1e-2, 4) > 1.0
    assert model.radius(model.linear, 1e-2, 1) < 1.0
    assert model.radius(model.linear, 2e-2, 4) < 1.0
    assert model.radius(model.linear, 1e-3, 4) < 1.0


def _substep_system(tmp_path, blower, max_time_step: float, stop: float) -> dict:
    sysd = couple_dynamic.load_dynamic_system(study.SYSTEM, tmp_path, max_time_step=max_time_step)
    sysd["fmu_paths"]["blower"] = blower
    sysd["inputs"]["cushion.snow"] = study.SNOW
    sysd["stop"] = stop
    return sysd


def test_the_real_system_follows_the_models_stability(blower_fmu, tmp_path, capfd):  # noqa: F811
    stable = _substep_system(tmp_path / "a", blower_fmu, 5e-3, 0.2)
    r = couple.run_system(stable, "newton", 0.02)
    assert not r.rejected
    assert r.records[-1].time == pytest.approx(0.2)
    unstable = _substep_system(tmp_path / "b", blower_fmu, 2.5e-3, 0.1)
    with pytest.raises(couple.CouplingError):
        couple.run_system(unstable, "newton", 0.01)
    capfd.readouterr()


def test_a_rolled_back_substepped_step_repeats_bit_for_bit(blower_fmu, tmp_path, capfd):  # noqa: F811
    """The cushion in four sub-steps per macro step, rolled back to a saved state after the
    snow: the repeated step, and the step after it (which starts from the restored step's
    velocities, accelerations and generalized-α history), equal the first run's bits."""
    sysd = _substep_system(tmp_path, blower_fmu, 2.5e-3, 0.1)
    m = couple.Master(sysd["fmu_paths"], sysd["connections"], sysd.get("inputs"),
                      {n: s.get("start", {}) for n, s in sysd["fmus"].items()})
    with m:
        m.run(0.03, 0.01, "newton")
        a = m.units["cushion"]
        s = a.save()
        runs = []
        for p in (250.0, 320.0, 250.0):
            a.restore(s)
            a.set({"p": p})
            a.step(0.03, 0.01)
            first = a.get(["V"])[0]
            a.step(0.04, 0.01)
            runs.append((first, a.get(["V"])[0]))
        a.free_state(s)
    assert runs[0] == runs[2]
    assert runs[0] != runs[1]
    capfd.readouterr()
