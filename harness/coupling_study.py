"""The cushion-and-blower system's coupling, measured (docs/coupling.md; a study, not a test):

1. for each macro step h, plain Gauss-Seidel's contraction on the first macro step (the ratio of
   successive interface residuals, median) against the loop gain J_B J_A = (dp/dV)(dV/dp) that
   the FMUs' directional derivatives give, and its iterations to 1e-10 (or where it diverges);
2. every method over the whole run (20 macro steps of 0.5 s): iterations per macro step, FMU
   steps, the largest relative difference to the monolithic answer, the cost of the interface
   Jacobian against one cushion step;
3. weak coupling (one Gauss-Seidel pass per step, accepted as it is): its error against the
   monolithic answer per macro step size.

    .venv/bin/python harness/coupling_study.py    # needs build/fmus/Blower.fmu (harness/setup.sh)

Writes build/plots/coupling_gs.png (residual histories of Gauss-Seidel per h).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from velarium import couple

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = ROOT / "examples" / "coupling" / "cushion_blower.json"


def main() -> None:
    sysd = couple.load_system(SYSTEM, ROOT / "build" / "coupling")
    compare = sysd["monolithic"]["compare"]
    histories = {}
    print("1. plain Gauss-Seidel on the first macro step")
    print(f"{'h':>6} {'gain J_B J_A':>13} {'measured ratio':>15} {'iterations':>11}")
    for h in (4.0, 2.0, 1.0, 0.5, 0.3, 0.25, 0.2, 0.15, 0.1):
        one = dict(sysd, stop=h)
        m = couple.Master(one["fmu_paths"], one["connections"], one.get("inputs"),
                          {n: s.get("start", {}) for n, s in one["fmus"].items()})
        with m:
            m.run(h, h, "newton")
            gain = float(m.units["blower"].jacobian(["p"], ["V"])[0, 0] * m.units["cushion"].jacobian(["V"], ["p"])[0, 0])
        try:
            r = couple.run_system(one, "gs", h, max_iterations=300, min_step=h)
            hist, its = r.records[1].history, str(r.records[1].iterations)
        except couple.CouplingError:
            hist, its = [], "diverges"
        hist = hist or _diverging_history(one, h)
        histories[h] = hist
        ratios = np.array(hist[1:]) / np.array(hist[:-1])
        print(f"{h:6.3g} {gain:13.4f} {np.median(ratios[: max(3, len(ratios) // 2)]):15.4f} {its:>11}")
    print("\n2. every method, 20 macro steps of 0.5 s (tolerance 1e-10)")
    ref = couple.monolithic(sysd)
    for method, opts in (("newton", {}), ("newton", {"jacobian": "fd"}), ("iqn", {}), ("aitken", {}),
                         ("gs", {"max_iterations": 100}), ("jacobi", {"max_iterations": 100})):
        r = couple.run_system(sysd, method, **opts)
        its = r.iterations[1:]
        d = couple.difference(r, ref, compare)
        label = method + (" (fd)" if opts.get("jacobian") == "fd" else "")
        print(f"{label:12} iterations {its.min()}-{its.max()} mean {its.mean():.2f}, FMU steps {r.fmu_steps}, "
              f"rejected {len(r.rejected)}, difference " + ", ".join(f"{k} {v:.1e}" for k, v in d.items()))
        if method == "newton" and not opts:
            (sa, ja, na), (sb, jb, nb) = r.timing["cushion"], r.timing["blower"]
            print(f"{'':12} cushion: {r.fmu_steps['cushion']} steps {1e3 * sa / r.fmu_steps['cushion']:.2f} ms each, "
                  f"{na} Jacobians {1e3 * ja / max(na, 1):.3f} ms each")
    print("\n3. weak coupling (one Gauss-Seidel pass per macro step)")
    for h in (0.5, 0.25, 0.1, 0.05):
        try:
            r = couple.run_system(sysd, "gs", h, weak=True)
            refh = couple.monolithic(sysd, h)
            d = couple.difference(r, refh, compare)
            print(f"h {h:5.3g}: difference " + ", ".join(f"{k} {v:.1e}" for k, v in d.items()))
        except couple.CouplingError as e:
            print(f"h {h:5.3g}: fails: {e}")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 4))
        for h, hist in histories.items():
            ax.semilogy(range(1, len(hist) + 1), hist, label=f"h = {h:g} s")
        ax.set_xlabel("coupling iteration")
        ax.set_ylabel("interface residual (relative)")
        ax.set_title("Plain Gauss-Seidel, first macro step")
        ax.set_xlim(0, 60)
        ax.legend(fontsize=7)
        out = ROOT / "build" / "plots" / "coupling_gs.png"
        out.parent.mkdir(parents=True, exist_ok=True)
        fig.tight_layout()
        fig.savefig(out, dpi=120)
        print(f"\nplot: {out}")
    except ImportError:
        pass


def _diverging_history(sysd, h) -> list[float]:
    """The residuals of a Gauss-Seidel attempt that does not converge (the master's record of
    the rejected attempt)."""
    m = couple.Master(sysd["fmu_paths"], sysd["connections"], sysd.get("inputs"),
                      {n: s.get("start", {}) for n, s in sysd["fmus"].items()})
    with m:
        try:
            m.run(h, h, "gs", max_iterations=300, min_step=h, log=None)
        except couple.CouplingError:
            pass
        return list(m.rejected[0][3]) if m.rejected else []


if __name__ == "__main__":
    sys.exit(main())
