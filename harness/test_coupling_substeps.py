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

The remedy, the gas's stiffness inside the sub-steps:

- In the model, the gas spring p(t) = p_lin(t) + k (u(t) − u_lin(t)) with u_lin going to the
  interface's end volume and k the gas's stiffness is the monolithic scheme: the two maps agree
  on states where the pressure is the gas law's (memoryless gas: 1.3e-13 relative measured; with
  the relieving blower, against the monolithic scheme with the gas amount linear over the
  sub-steps), measured 3.1e-9 and 1.9e-9 relative over h = 1 ms to 50 ms and 1-8 sub-steps
  (the affine fits' round-off with k_g ≈ 2.2e6, as above, here through up to 8 sub-steps),
  tolerance 1e-8. Anchored at the start volume instead, it is another discretization: its map
  differs from the end-anchored one by 73 % (relative, on those states) already with one
  sub-step (h = 10 ms), asserted > 1 %.
- Radii (the relieving blower, 4 sub-steps, h = 5 ms): plain 2.458, gas spring with the gas's
  stiffness 0.984 (the monolithic scheme's), with the blower's dp/dV over the step 1.001. The
  test asserts the side of 1 (and 2) for the first two, and, over the whole table (h 1 ms to
  0.1 s, 1-8 sub-steps), the blower's dp/dV spring's worst radius below 1.1 (1.059 measured, at
  2.5 ms in 4 sub-steps) where the plain scheme's exceeds 2 (2.553).
- The blower's dN = N − N_ref output: its directional derivative after a step against the
  central difference of two steps from the saved state (δ = 1e-6 V), as dp/dV in
  test_coupling.py: measured 1.4e-10 relative, tolerance 1e-9.
- The real system coupled through the gas amount (harness/coupling_gas_interface.py: the
  cushion's `gas` scene, the gas law in every sub-step) at h = 5 ms in sub-steps of 1.25 ms,
  where the pressure interface fails: it runs 0.1 s with no step rejected and agrees with the
  dynamic monolithic answer of the same sub-step to 3.7e-12 in p and 2.0e-13 in V (measured;
  the interface tolerance, 1e-12 in m³ of gas, bounds it by about 4e-10 of p per step),
  tolerance 4e-11 and 2e-12 (the numbers are deterministic: the same binary gives the same
  bits).
"""

from __future__ import annotations

import numpy as np
import pytest

from test_coupling import blower_fmu  # noqa: F401  (the session fixture that packs harness/blower/)

import coupling_substep_model as model

from test_coupling import blower as _blower_instance

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


# ---- the remedy: the gas's stiffness inside the sub-steps


def _consistent_states(relief: bool):
    """States whose pressure is the gas law's: (u, v, a, p = −k_g u) and, with the relieving
    blower, (u, v, a, p = k_g (w − u), w)."""
    out = []
    for u, v, a, w in ([1.0, 0.3, -5.0, 0.2], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]):
        out.append(np.array([u, v, a, model.K_G * (w - u), w]) if relief else np.array([u, v, a, -model.K_G * u]))
    return out


def _worst_relative(f, g, states, cases):
    worst = 0.0
    for h, n in cases:
        for x in states:
            a, b = f(x, h, n), g(x, h, n)
            worst = max(worst, float(np.max(np.abs(a - b)) / np.max(np.abs(b))))
    return worst


CASES = [(h, n) for h in (1e-3, 5e-3, 1e-2, 5e-2) for n in (1, 2, 4, 8)]


def test_the_gas_spring_with_the_gas_stiffness_is_the_monolithic_scheme():
    # memoryless gas: the spring anchored at the interface's end volume, k the gas's stiffness
    memoryless = [x[:4] for x in _consistent_states(False) if np.any(x)]

    def spring0(x, h, n):
        y = model.spring(np.append(x, 0.0), h, n, "gas", relief=0.0)
        return y[:4]

    assert _worst_relative(spring0, model.monolithic, memoryless, CASES) < 1e-8
    # the relieving blower: against the monolithic scheme (the gas amount linear over the sub-steps)
    assert _worst_relative(lambda x, h, n: model.spring(x, h, n, "gas"), model.monolithic_relief,
                           _consistent_states(True), CASES) < 1e-8


def test_the_gas_spring_anchored_at_the_start_volume_is_another_discretization():
    one = [(1e-2, 1)]
    d = _worst_relative(lambda x, h, n: model.spring(x, h, n, anchor="start"),
                        lambda x, h, n: model.spring(x, h, n), _consistent_states(True), one)
    assert d > 1e-2


def test_the_gas_spring_is_stable_where_the_plain_scheme_is_not():
    h, n = 5e-3, 4
    assert model.radius(lambda x, h, n: model.spring(x, h, n, "none"), h, n) > 2.0
    assert model.radius(lambda x, h, n: model.spring(x, h, n, "gas"), h, n) < 1.0
    table = [(h, n) for h in (1e-3, 2.5e-3, 5e-3, 1e-2, 2e-2, 5e-2, 0.1) for n in (1, 2, 4, 8)]
    assert max(model.radius(model.spring, h, n) for h, n in table) < 1.1
    assert max(model.radius(lambda x, h, n: model.spring(x, h, n, "none"), h, n) for h, n in table) > 2.0


def test_the_blowers_gas_amount_output_and_its_derivative(blower_fmu):  # noqa: F811
    s, vrs, _ = _blower_instance(blower_fmu, V0=0.7, p0=200.0, N_ref=0.65)
    try:
        s.setReal([vrs["p_set"], vrs["V"]], [300.0, 0.7])
        s.doStep(0.0, 0.5)
        n, dn = s.getReal([vrs["N"], vrs["dN"]])
        assert dn == n - 0.65
        saved = s.getFMUstate()

        def dn_after(V):
            s.setFMUstate(saved)
            s.setReal([vrs["V"]], [V])
            s.doStep(0.5, 0.5)
            return s.getReal([vrs["dN"]])[0]

        V, d = 0.72, 0.72e-6
        dn_after(V)
        der = s.getDirectionalDerivative([vrs["dN"]], [vrs["V"]], [1.0])[0]
        fd = (dn_after(V + d) - dn_after(V - d)) / (2 * d)
        assert der == pytest.approx(fd, rel=1e-9)
        s.freeFMUstate(saved)
    finally:
        s.terminate()
        s.freeInstance()


def test_the_real_system_through_the_gas_amount_is_stable_and_monolithic(blower_fmu, tmp_path, capfd):  # noqa: F811
    gas = pytest.importorskip("coupling_gas_interface")
    sysd = gas.pressure_system(tmp_path, blower_fmu, 1.25e-3, 0.1)
    with pytest.raises(couple.CouplingError):  # the pressure interface fails there
        gas.run(sysd, 5e-3)
    ref = couple_dynamic.monolithic(sysd, 5e-3)
    r = gas.run(gas.gas_system(sysd), 5e-3, tol=gas.GAS_TOL)
    assert not r.rejected
    assert r.records[-1].time == pytest.approx(0.1)
    d = gas.compare(r, ref)
    assert d["cushion.p"] < 4e-11 and d["cushion.V"] < 2e-12
    capfd.readouterr()
