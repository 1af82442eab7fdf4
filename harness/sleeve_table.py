"""Seed paper Table 1 from the SleeveCable FMU: our numbers beside the experiment, and plots.

Drives build/fmus/SleeveCable.fmu through fmpy over the Table 1 load points (2P = 0, 1, 2, 4,
5 N, one co-simulation step each, in that order: the sleeve friction makes the answer depend on
the load path) with the given (or calibrated) rubber shear modulus and sleeve friction
coefficient, prints ours beside reference/seed_table1.csv with the Newton iterations of every
step, and writes

    build/plots/SleeveCable_table1.png   load against A_dx, A_dy, B_dy, L_c: ours and experiment
    build/plots/SleeveCable_deformed.png the deformed sheet at 2P = 5 N, wrinkled elements
                                         coloured, the cable drawn (velarium solve --elements)

    .venv/bin/python harness/sleeve_table.py [--mu-rubber PA] [--mu-friction MU]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import fmpy
import numpy as np

import velarium_run as vr

FMU = vr.FMU_DIR / "SleeveCable.fmu"
SCENE = vr.SCENES / "SleeveCable" / "scene.json"
TABLE = Path(__file__).resolve().parent / "seed_table1.csv"  # the seed paper's Table 1
CALIBRATION = vr.ROOT / "build" / "sleeve_calibration.json"
PLOTS = vr.ROOT / "build" / "plots"
# The scene's constant pull on the cable's free end (its start value), N.
PRELOAD = 0.3
# The readings of Fig. 1 (docs/mechanics.md §7) and the constant cable-end pulls each keeps at its
# start value during the Table 1 path, N.
READINGS = {
    "SleeveCable": {"cable_preload": PRELOAD},
    "SleeveDrawstring": {"cable_preload_top": 0.15, "cable_preload_bottom": 0.15},
}
# Table 1 columns and our outputs, in m.
QUANTITIES = [("node_A_dx_m", "A_dx"), ("node_A_dy_m", "A_dy"), ("node_B_dy_m", "B_dy"), ("cable_length_m", "L_c")]


def experiment() -> np.ndarray:
    lines = [line for line in TABLE.read_text().splitlines() if line and not line.startswith("#")]
    return np.genfromtxt(lines, delimiter=",", names=True)


def run(mu_rubber: float, mu_friction: float, loads: np.ndarray, logger=None, scene: str = "SleeveCable") -> np.ndarray:
    """One FMU run of the reading `scene`: step k carries loads[k] (fmpy records after DoStep, so
    row k+1 is the equilibrium under loads[k]). `logger` replaces fmpy's printing of the FMU's
    messages (fmpy's signature: component environment, instance name, status, category,
    message). A step the FMU discards ends the run: fewer rows than loads come back."""
    n = len(loads)
    preloads = READINGS[scene]
    signal = np.zeros(n, dtype=[("time", np.float64), ("force_2P", np.float64)] + [(k, np.float64) for k in preloads])
    signal["time"] = np.arange(n, dtype=float)
    signal["force_2P"] = loads
    for k, v in preloads.items():
        signal[k] = v
    # Through velarium_run: a logger passed to fmpy.simulate_fmu directly leaves fmpy's native
    # proxy pointing at freed memory after the run (docs/fmu.md, "fmpy's logger").
    rows = vr.simulate_fmu(
        vr.FMU_DIR / f"{scene}.fmu",
        start_time=0.0,
        stop_time=float(n),
        output_interval=1.0,
        input=signal,
        start_values={"mu_rubber": mu_rubber, "mu_friction": mu_friction},
        validate=False,
        timeout=vr.TIMEOUT,
        **({"logger": logger} if logger is not None else {}),
    )
    return rows[1:]


def calibrated() -> tuple[float, float]:
    if CALIBRATION.is_file():
        c = json.loads(CALIBRATION.read_text())
        return c["mu_rubber"], c["mu_friction"]
    scene = json.loads(SCENE.read_text())
    return scene["membranes"][0]["material"]["mu"], scene["cables"][0]["sleeve"]["mu"]


def print_comparison(exp: np.ndarray, ours: np.ndarray, mu_rubber: float, mu_friction: float) -> None:
    print(f"\nSeed paper Table 1 against SleeveCable (mu_rubber = {mu_rubber:.4g} Pa, mu_friction = {mu_friction:.4g}); mm")
    header = ["2P [N]"] + [f"{q} exp / ours" for _, q in QUANTITIES] + ["Newton it."]
    print("  ".join(h.rjust(18) for h in header))
    for k in range(len(exp)):
        cells = [f"{exp['force_2P_N'][k]:g}"]
        for col, out in QUANTITIES:
            cells.append(f"{1e3 * exp[col][k]:7.2f} / {1e3 * ours[out][k]:7.2f}")
        cells.append(str(int(ours["newton_iterations"][k])))
        print("  ".join(c.rjust(18) for c in cells))
    its = [int(i) for i in ours["newton_iterations"][1:]]
    print(f"Newton iterations per load step (steps 1-{len(its)}): {list(its)}, median {np.median(its):g}")
    err = np.concatenate([1e3 * (ours[o][1:] - exp[c][1:]) for c, o in QUANTITIES])
    print(f"RMS error over the {len(err)} loaded entries: {np.sqrt(np.mean(err ** 2)):.2f} mm")
    for c, o in QUANTITIES:
        e = 1e3 * (ours[o][1:] - exp[c][1:])
        print(f"  {o:5s} RMS {np.sqrt(np.mean(e ** 2)):6.2f} mm, monotone increasing in 2P: {bool(np.all(np.diff(ours[o]) > 0))}")


def plot_table(exp: np.ndarray, ours: np.ndarray, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(16, 3.8))
    for ax, (col, out) in zip(axes, QUANTITIES):
        ax.plot(exp["force_2P_N"], 1e3 * exp[col], "ks--", label="experiment (Table 1)")
        ax.plot(exp["force_2P_N"], 1e3 * ours[out], "o-", label="SleeveCable FMU")
        ax.set_xlabel("2P [N]")
        ax.set_ylabel(f"{out} [mm]")
        ax.grid(True, alpha=0.3)
    axes[0].legend()
    fig.suptitle("Seed paper Table 1: cable slip in an edge sleeve")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_deformed(mu_rubber: float, mu_friction: float, loads: np.ndarray, path: Path) -> None:
    """The deformed sheet at the last load (velarium solve, same scene and history), wrinkled
    elements coloured, the cable drawn through its sleeve nodes to its free end."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch

    import plot_elements

    scene = json.loads(SCENE.read_text())
    scene["membranes"][0]["material"]["mu"] = mu_rubber
    scene["cables"][0]["sleeve"]["mu"] = mu_friction
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "scene.json").write_text(json.dumps(scene))
        lines = ["time,force_2P,cable_preload"] + [f"{k},{float(p)!r},{PRELOAD!r}" for k, p in enumerate(loads)]
        (tmp / "loads.csv").write_text("\n".join(lines) + "\n")
        run = subprocess.run(
            [str(vr.VELARIUM), "solve", str(tmp / "scene.json"), "--loads", str(tmp / "loads.csv"),
             "--out", str(tmp / "out.csv"), "--elements", str(tmp / "elements.csv")],
            capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"velarium solve failed:\n{run.stderr}")
        elements = plot_elements.load(tmp / "elements.csv")
        out = vr.read_csv(tmp / "out.csv")
    last = elements[np.isclose(elements["time"], elements["time"].max())]
    end = out[-1]
    tris = np.stack([np.column_stack([last[f"x{k}"], last[f"y{k}"]]) for k in (1, 2, 3)], axis=1)
    states = last["state"].astype(int)
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.add_collection(PolyCollection(tris, facecolors=[plot_elements.COLOURS[s] for s in states], edgecolors="white", linewidths=0.4))
    # The cable: the sleeve (top edge) vertices from C to A, then the free end.
    top = scene["geometry"]["generators"][0]["size"][1]
    sleeve = sleeve_chain(tris, top, scene["geometry"]["generators"][0]["divisions"][0])
    ax.plot(sleeve[:, 0], sleeve[:, 1], "-", color="crimson", lw=2.2, label="cable in the sleeve")
    ax.plot([sleeve[-1, 0], end["end_x"]], [sleeve[-1, 1], end["end_y"]], "--", color="crimson", lw=1.5, label="free cable end")
    ax.plot(sleeve[-1, 0], sleeve[-1, 1], "ko")
    ax.annotate("A", sleeve[-1], textcoords="offset points", xytext=(4, 6))
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    counts = {plot_elements.NAMES[k]: int(np.sum(states == k)) for k in plot_elements.NAMES}
    ax.set_title(f"SleeveCable at 2P = {loads[-1]:g} N: " + ", ".join(f"{n} {c}" for n, c in counts.items()))
    handles = [Patch(color=plot_elements.COLOURS[k], label=plot_elements.NAMES[k]) for k in plot_elements.NAMES]
    ax.legend(handles=handles + ax.get_legend_handles_labels()[0], loc="lower right", fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def sleeve_chain(tris: np.ndarray, top: float, segments: int) -> np.ndarray:
    """The deformed top boundary from the clamped corner C (0, top) to node A: `segments`
    boundary edges (edges used by one triangle) walked from C along the top, away from the
    clamped left edge."""
    from collections import defaultdict

    def key(p):
        return (round(float(p[0]), 12), round(float(p[1]), 12))

    count = defaultdict(int)
    for t in tris:
        for a, b in ((0, 1), (1, 2), (2, 0)):
            count[tuple(sorted((key(t[a]), key(t[b]))))] += 1
    graph = defaultdict(list)
    for (a, b), n in count.items():
        if n == 1 and not (abs(a[0]) < 1e-12 and abs(b[0]) < 1e-12):
            graph[a].append(b)
            graph[b].append(a)
    chain = [min(graph, key=lambda p: p[0] ** 2 + (p[1] - top) ** 2)]
    prev = None
    for _ in range(segments):
        nxt = [q for q in graph[chain[-1]] if q != prev]
        if not nxt:
            break
        prev = chain[-1]
        chain.append(max(nxt, key=lambda p: p[1]))
    return np.array(chain)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mu_r, mu_f = calibrated()
    parser.add_argument("--mu-rubber", type=float, default=mu_r, help="rubber shear modulus [Pa] (default: calibrated, else the scene's)")
    parser.add_argument("--mu-friction", type=float, default=mu_f, help="sleeve friction coefficient (default: calibrated, else the scene's)")
    args = parser.parse_args(argv)
    if not FMU.is_file():
        sys.exit(f"{FMU} is missing: run bash harness/main.sh")
    exp = experiment()
    loads = np.asarray(exp["force_2P_N"], dtype=float)
    ours = run(args.mu_rubber, args.mu_friction, loads)
    print_comparison(exp, ours, args.mu_rubber, args.mu_friction)
    plot_table(exp, ours, PLOTS / "SleeveCable_table1.png")
    plot_deformed(args.mu_rubber, args.mu_friction, loads, PLOTS / "SleeveCable_deformed.png")
    print(f"wrote {(PLOTS / 'SleeveCable_table1.png').relative_to(vr.ROOT)}, {(PLOTS / 'SleeveCable_deformed.png').relative_to(vr.ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
