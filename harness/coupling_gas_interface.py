"""The gas's stiffness inside the cushion's sub-steps, on the real system (docs/coupling.md,
"Sub-steps inside the macro step"): the cushion-and-blower system with the cushion's mass,
coupled through the gas amount instead of the pressure.

The coupled scheme fails with sub-steps inside the macro step because the cushion sees the
pressure as a prescribed load over its sub-steps: the gas's stiffness, 38 times the skins', is
explicit there (harness/coupling_substep_model.py). The remedy the model says works is a gas
spring inside the sub-steps, p(t) = p_lin(t) + k (V(t) - V_lin(t)), V_lin going to the
interface's end volume, with k the gas's own stiffness: that is the coupled scheme whose maps
equal the monolithic ones. Velarium's `gas` input is that spring with the exact (nonlinear,
isothermal) law: the cushion's `gas` scene (`examples/coupling/cushion_gas.json`, the
monolithic reference's scene) takes the gas amount ΔN = N - V⁰, which goes linearly over its
sub-steps, and solves (p + p_atm) V = p_atm (V⁰ + ΔN) in every one of them. So here the blower
gives the gas amount (its output dN = N - N_ref, N_ref = V⁰) and the cushion the volume:

    connections  cushion.V -> blower.V,  blower.dN -> cushion.dN

At a converged interface the blower's backward-Euler balance holds at the macro step's end
with the gas law the cushion solved there, and the cushion's sub-steps are the monolithic
reference's (couple_monolithic.solve drives the same scene with ΔN linear over its sub-steps):
the same discrete equations, so the two should agree to the interface's tolerance, sub-steps
or not.

    .venv/bin/python harness/coupling_gas_interface.py   # needs build/fmus/Blower.fmu

prints, per (macro step, sub-step), the pressure-interface run (which fails in the band) and
the gas-amount-interface run: iterations per macro step, steps rejected, and the largest
relative difference of p and V to the dynamic monolithic answer of the same sub-step.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from velarium import couple, couple_dynamic

import coupling_dynamic_study as study

ROOT = Path(__file__).resolve().parent.parent
BLOWER = ROOT / "build" / "fmus" / "Blower.fmu"
COMPARE = {"cushion.p": "p", "cushion.V": "V"}
#: the gas-amount interface's tolerance: the master scales the residual by max(|x|, 1), and
#: ΔN is a few 1e-3 m³, so its default 1e-10 is an absolute 1e-10 m³ of gas, 4e-8 of the
#: pressure (dp/dN = p_atm/V ≈ 7.8e4 Pa/m³); 1e-12 brings it to the pressure's 1e-10
GAS_TOL = 1e-12


def pressure_system(build: Path, blower: Path, max_time_step: float, stop: float) -> dict[str, Any]:
    """The example with the cushion's mass, coupled through the pressure (the shipped wiring),
    the cushion in sub-steps of ``max_time_step``, the sudden snow of the dynamic study."""
    sysd = couple_dynamic.load_dynamic_system(study.SYSTEM, build, max_time_step=max_time_step)
    sysd["fmu_paths"]["blower"] = blower
    sysd["inputs"]["cushion.snow"] = study.SNOW
    sysd["stop"] = stop
    return sysd


def gas_system(sysd: dict[str, Any]) -> dict[str, Any]:
    """The same system (``pressure_system``) coupled through the gas amount
    (``couple_dynamic.gas_amount_system``: the cushion is the dynamic `gas` scene of its
    monolithic entry, the blower gives it ``dN``)."""
    return couple_dynamic.gas_amount_system(sysd)


def run(sysd: dict[str, Any], step: float, method: str = "newton", **options) -> couple.Result:
    m = couple.Master(sysd["fmu_paths"], sysd["connections"], sysd.get("inputs"),
                      {n: s.get("start", {}) for n, s in sysd["fmus"].items()})
    with m:
        return m.run(float(sysd["stop"]), step, method, record=list(COMPARE), **options)


def compare(result: couple.Result, ref: dict[str, np.ndarray]) -> dict[str, float]:
    return couple.difference(result, ref, COMPARE)


def main() -> None:
    build = ROOT / "build" / "coupling_gas_interface"
    blower = BLOWER
    if not blower.is_file():
        sys.exit(f"{blower} is missing: python3 harness/blower/pack.py build/fmus")
    stop = 0.2
    cases = [(1e-3, 2.5e-4), (2.5e-3, 6.25e-4), (5e-3, 1.25e-3), (5e-3, 2.5e-3), (1e-2, 2.5e-3), (1e-2, 5e-3),
             (2e-2, 5e-3), (5e-2, 1.25e-2)]
    if len(sys.argv) > 1:
        cases = [c for c in cases if f"{c[0]:g}" in sys.argv[1:]]
    print(f"0-{stop} s, snow 0 -> 200 Pa between 0.02 and 0.03 s; Newton with the FMUs' derivatives, "
          f"tolerance 1e-10 (pressure interface), {GAS_TOL:g} (gas interface)")
    for h, dt in cases:
        sysd = pressure_system(build / f"h{h:g}_dt{dt:g}", blower, dt, stop)
        t0 = time.perf_counter()
        ref = couple_dynamic.monolithic(sysd, h)
        t_ref = time.perf_counter() - t0
        line = f"h {h:g} s / sub-step {dt:g} s ({round(h / dt)}): monolithic {t_ref:.0f} s"
        try:
            r = run(sysd, h)
            d = compare(r, ref)
            line += (f" | pressure interface: runs, iterations {r.iterations[1:].min()}-{r.iterations[1:].max()}, "
                     f"rejected {len(r.rejected)}, diff p {d['cushion.p']:.2g} V {d['cushion.V']:.2g}")
        except couple.CouplingError as e:
            line += f" | pressure interface: fails ({str(e)[:60]})"
        gsys = gas_system(sysd)
        t0 = time.perf_counter()
        r = run(gsys, h, tol=GAS_TOL)
        its = r.iterations[1:]
        d = compare(r, ref)
        line += (f" | gas interface: iterations {its.min()}-{its.max()} (mean {its.mean():.2f}), rejected "
                 f"{len(r.rejected)}, cushion steps {r.fmu_steps['cushion']}, diff p {d['cushion.p']:.2g} "
                 f"V {d['cushion.V']:.2g} ({time.perf_counter() - t0:.0f} s)")
        print(line, flush=True)


if __name__ == "__main__":
    main()
