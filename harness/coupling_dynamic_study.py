"""The cushion-and-blower system with the cushion's mass, measured (docs/coupling.md, "The
dynamic system"; a study, not a test).

The example system with both cushion scenes made dynamic (``velarium.couple_dynamic``: foil
density 1750 kg/m³, Rayleigh α 20/s, generalized-α ρ∞ 0.9) and a sudden snow load (0 -> 200 Pa
between 0.02 and 0.03 s), 0.1 s:

1. the loop gain J_B J_A per macro step h from the initial state (the blower's derivative, the
   cushion's from its step's derivative, GetDirectionalDerivative, beside a forward difference
   of its step from the saved state), and plain Gauss-Seidel's iterations on that step;
2. every method at several h (Newton with the FMUs' derivatives and with finite differences
   of steps): iterations, rejected (halved) steps, FMU steps, the Jacobians' share of the
   cushion's time and the largest relative difference to the dynamic monolithic answer at the
   same h;
3. the monolithic answer at each h against the one at h = 0.25 ms (the time discretisation);
4. the cushion in sub-steps of 2.5 ms inside 10 ms macro steps: Newton with the derivatives
   through the sub-steps and with differences, the coupled pressure against the monolithic
   one, and where the coupled run fails.

    .venv/bin/python harness/coupling_dynamic_study.py   # needs build/fmus/Blower.fmu

Writes build/plots/coupling_dynamic.png (the loop gain against h; V and p of the strong run
beside the monolithic answer).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from velarium import couple, couple_dynamic

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = ROOT / "examples" / "coupling" / "cushion_blower.json"
SNOW = [[0, 0], [0.02, 0], [0.03, 200]]


def system(build: Path, blower: Path | None = None, stop: float = 0.1) -> dict:
    sysd = couple_dynamic.load_dynamic_system(SYSTEM, build)
    if blower is not None:
        sysd["fmu_paths"]["blower"] = blower
    sysd["inputs"]["cushion.snow"] = SNOW
    sysd["stop"] = stop
    return sysd


def loop_gain(sysd: dict, hs) -> list[tuple[float, float, float, float]]:
    """(h, dV/dp of the cushion's step from its derivative, dp/dV of the blower's, dV/dp of the
    cushion's step by a forward difference) from the initial state."""
    m = couple.Master(sysd["fmu_paths"], sysd["connections"], sysd.get("inputs"),
                      {n: s.get("start", {}) for n, s in sysd["fmus"].items()})
    out = []
    with m:
        # initialize only: a run whose first macro step is a micro step that Gauss-Seidel converges
        m.run(1e-4, 1e-4, "gs")
        A, B = m.units["cushion"], m.units["blower"]
        sa, sb = A.save(), B.save()
        x = B.get(["p"])
        for h in hs:
            t = 1e-4
            ya = m._step_a(sa, x, t, h)
            ja = A.jacobian(["V"], ["p"])[0, 0]
            fd = m._fd_jacobian(m._step_a, sa, x, t, h, ya)[0, 0]
            m._step_b(sb, ya, t, h)
            jb = B.jacobian(["p"], ["V"])[0, 0]
            out.append((h, ja, jb, fd))
        A.free_state(sa)
        B.free_state(sb)
    return out


def main() -> None:
    build = ROOT / "build" / "coupling_dynamic"
    sysd = system(build)
    hs = (2.0, 1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001, 5e-4, 2.5e-4)
    print("1. loop gain J_B J_A of one macro step from the initial state, and Gauss-Seidel on it")
    print(f"{'h':>8} {'dV/dp cushion':>14} {'its fd':>9} {'dp/dV blower':>13} {'gain':>9} {'gs iterations':>14}")
    gains = loop_gain(sysd, hs)
    for h, ja, jb, fd in gains:
        one = dict(sysd, stop=h)
        try:
            r = couple.run_system(one, "gs", h, max_iterations=300, min_step=h)
            its = str(r.records[1].iterations)
        except couple.CouplingError:
            its = "diverges"
        print(f"{h:8g} {ja:14.4e} {abs(fd - ja) / abs(ja):9.1e} {jb:13.4e} {ja * jb:9.4f} {its:>14}")
    print("\n2. every method over 0.1 s (tolerance 1e-10), against the dynamic monolithic answer at the same h")
    runs = {}
    for h in (0.1, 0.01, 0.001):
        ref = couple_dynamic.monolithic(sysd, h)
        for method in ("newton", "newton-fd", "iqn", "aitken", "gs", "jacobi"):
            t0 = time.process_time()
            opts = {"jacobian": "fd"} if method == "newton-fd" else {}
            try:
                r = couple.run_system(sysd, method.split("-")[0], h,
                                      max_iterations=100 if method in ("gs", "jacobi") else 20, **opts)
            except couple.CouplingError as e:
                print(f"h {h:6g} {method:7} fails: {str(e)[:120]}")
                continue
            its = r.iterations[1:]
            d = couple.difference(r, ref, sysd["monolithic"]["compare"])
            step_s, jac_s, jacs = r.timing["cushion"]
            jac = f", cushion: {jacs} Jacobians {jac_s / max(jacs, 1) * 1e3:.2f} ms each, steps {step_s / r.fmu_steps['cushion'] * 1e3:.2f} ms each" if jacs else ""
            print(f"h {h:6g} {method:9} iterations {its.min()}-{its.max()} mean {its.mean():5.2f}, rejected {len(r.rejected):3d}, "
                  f"FMU steps {r.fmu_steps}, difference p {d['cushion.p']:.1e} V {d['cushion.V']:.1e} N {d['blower.N']:.1e}, "
                  f"{time.process_time() - t0:.2f} CPU s{jac}")
            runs[h, method] = r
        runs[h, "ref"] = ref
    print("\n3. the monolithic answer at h against h = 0.25 ms (largest relative difference at the common times)")
    fine = couple_dynamic.monolithic(sysd, 2.5e-4)
    for h in (0.1, 0.01, 0.001):
        ref = runs[h, "ref"]
        idx = [int(np.argmin(np.abs(fine["time"] - t))) for t in ref["time"]]
        dp = np.max(np.abs(ref["p"] - fine["p"][idx]) / np.abs(fine["p"][idx]))
        dv = np.max(np.abs(ref["V"] - fine["V"][idx]) / np.abs(fine["V"][idx]))
        print(f"h {h:6g}: p {dp:.2e}, V {dv:.2e}")
    print("\n4. sub-steps of 2.5 ms inside macro steps of 10 ms (max_time_step)")
    sub = couple_dynamic.load_dynamic_system(SYSTEM, build / "substeps", max_time_step=2.5e-3)
    sub["inputs"]["cushion.snow"] = SNOW
    sub["stop"] = 0.07
    ref = couple_dynamic.monolithic(sub, 0.01)
    for jac in ("auto", "fd"):
        r = couple.run_system(sub, "newton", 0.01, jacobian=jac)
        print(f"newton, jacobian {jac}: iterations {r.iterations[1:].tolist()}, rejected {len(r.rejected)}, "
              f"FMU steps {r.fmu_steps}")
        print("  coupled p    ", np.round(r.column("cushion.p"), 1).tolist())
    print("  monolithic p ", np.round(ref["p"], 1).tolist())
    for m in (2.5e-3, 5e-3):
        longer = couple_dynamic.load_dynamic_system(SYSTEM, build / "substeps", max_time_step=m)
        longer["inputs"]["cushion.snow"] = SNOW
        try:
            couple.run_system(longer, "newton", 0.01)
            print(f"max_time_step {m:g}: 0.1 s run to the end")
        except couple.CouplingError as e:
            print(f"max_time_step {m:g}: {e}")
    _plot(gains, runs, fine, ROOT / "build" / "plots" / "coupling_dynamic.png")


def _plot(gains, runs, fine, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    h = np.array([g[0] for g in gains])
    g = np.array([abs(g[1] * g[2]) for g in gains])
    ax[0].loglog(h, g, "o-", label="|J_B J_A| (cushion with mass)")
    ax[0].axhline(1.0, color="k", ls="--", lw=0.8, label="Gauss-Seidel's limit")
    ax[0].set_xlabel("macro step h (s)")
    ax[0].set_ylabel("loop gain")
    ax[0].set_title("weak coupling converges where the gain < 1")
    ax[0].legend()
    for k, (col, rc, lab) in enumerate((("cushion.p", "p", "p (Pa)"), ("cushion.V", "V", "V (m³)"))):
        a = ax[k + 1]
        a.plot(fine["time"], fine[rc], "k-", lw=0.8, label="monolithic, h = 0.25 ms")
        for hh, style in ((0.01, "o"), (0.001, ".")):
            if (hh, "newton") in runs:
                r = runs[hh, "newton"]
                a.plot(r.times, r.column(col), style, ms=4, label=f"newton, h = {hh:g} s")
        if (0.001, "gs") in runs:
            r = runs[0.001, "gs"]
            a.plot(r.times, r.column(col), "-", lw=0.6, label="gs, h = 0.001 s")
        a.set_xlabel("t (s)")
        a.set_ylabel(lab)
        a.legend(fontsize=7)
    ax[1].set_title("snow 0 -> 200 Pa over 0.02-0.03 s")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
