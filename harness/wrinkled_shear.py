"""WrinkledShear through fmpy: pretension, then shear, with the membrane's wrinkle states drawn.

The shipped scene (Wong & Pellegrino's shear test; Kapton 380 x 128 mm, clamped long edges)
starts pretensioned by its edge separation (1 mm). This script shears its top edge from 0 to
3 mm in 20 communication steps with ``fmpy.simulate_fmu`` (one extra step at the end, because
the row fmpy records at t_{k+1} carries the input set at t_k), prints the loads, the shear
force, the wrinkled and slack fractions and the FMU's Newton iterations per step with their
median, and writes

    build/plots/WrinkledShear.png            shear force and wrinkled / slack fractions vs shear
    build/plots/WrinkledShear_elements.png   the film at 3 mm coloured by state (taut, wrinkled,
                                             slack) with the tension direction of every wrinkled
                                             triangle (from ``velarium solve --elements``)

Run by ``bash harness/main.sh``; alone: ``.venv/bin/python harness/wrinkled_shear.py`` after the
FMUs are packed.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import plot_elements
import velarium_run as vr

NAME = "WrinkledShear"
STEPS = 20
MAX_SHEAR = 3e-3
PLOTS = vr.ROOT / "build" / "plots"


def shear_table(separation: float) -> np.ndarray:
    """time, separation (held), shear 0 → MAX_SHEAR over STEPS steps of 0.05, plus one step."""
    h = 1.0 / STEPS
    rows = STEPS + 2
    table = np.zeros(rows, dtype=[("time", np.float64), ("separation", np.float64), ("shear", np.float64)])
    table["time"] = [k * h for k in range(rows)]
    table["separation"] = separation
    table["shear"] = [MAX_SHEAR * min(k, STEPS) / STEPS for k in range(rows)]
    return table


def main() -> int:
    fmu = vr.FMU_DIR / f"{NAME}.fmu"
    if not fmu.is_file():
        sys.exit(f"{fmu} is missing: run bash harness/main.sh (it packs every shipped scene)")
    import fmpy

    md = fmpy.read_model_description(str(fmu))
    separation = float(next(v.start for v in md.modelVariables if v.name == "separation"))
    table = shear_table(separation)
    rows = vr.simulate(fmu, table)
    # Row k+1 carries the input set at row k (the co-simulation lag); row 0 the start values.
    shear = np.concatenate([table["shear"][:1], table["shear"][:-1]])
    print(f"\n{NAME}: separation {separation * 1e3:g} mm, shear 0 -> {MAX_SHEAR * 1e3:g} mm in {STEPS} steps\n")
    print(f"{'shear [mm]':>11} {'shear_force [N]':>16} {'wrinkled':>9} {'slack':>7} {'iterations':>11}")
    for k, row in enumerate(rows):
        print(f"{shear[k] * 1e3:11.3f} {row['shear_force']:16.4f} {row['wrinkled_fraction']:9.3f} "
              f"{row['slack_fraction']:7.3f} {int(row['newton_iterations']):11d}")
    steps = rows["newton_iterations"][2:]  # the steps that sheared (row 1 repeats the start)
    print(f"\nNewton iterations per shear step: median {np.median(steps):g}, max {int(steps.max())}")

    PLOTS.mkdir(parents=True, exist_ok=True)
    plot_history(shear, rows, PLOTS / f"{NAME}.png")
    with tempfile.TemporaryDirectory() as tmp:
        elements = Path(tmp) / "elements.csv"
        loads = Path(tmp) / "loads.csv"
        vr.write_loads_csv(table[: STEPS + 1], loads)
        scene = vr.SCENES / NAME / "scene.json"
        run = subprocess.run([str(vr.VELARIUM), "solve", str(scene), "--loads", str(loads), "--out", str(Path(tmp) / "out.csv"),
                              "--elements", str(elements)], capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"velarium solve failed:\n{run.stderr}")
        data = plot_elements.load(elements)
        last = data[np.isclose(data["time"], data["time"].max())]
        counts = {plot_elements.NAMES[k]: int(np.sum(last["state"] == k)) for k in plot_elements.NAMES}
        title = f"{NAME}, shear {MAX_SHEAR * 1e3:g} mm: " + ", ".join(f"{n} {c}" for n, c in counts.items())
        plot_elements.plot(last, PLOTS / f"{NAME}_elements.png", title)
    print(f"wrote {(PLOTS / f'{NAME}.png').relative_to(vr.ROOT)} and {(PLOTS / f'{NAME}_elements.png').relative_to(vr.ROOT)}")
    return 0


def plot_history(shear: np.ndarray, rows: np.ndarray, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    a.plot(shear * 1e3, rows["shear_force"], "o-")
    a.set_xlabel("shear [mm]")
    a.set_ylabel("shear force [N]")
    b.plot(shear * 1e3, rows["wrinkled_fraction"], "o-", label="wrinkled")
    b.plot(shear * 1e3, rows["slack_fraction"], "s-", label="slack")
    b.set_xlabel("shear [mm]")
    b.set_ylabel("area fraction")
    b.legend()
    for ax in (a, b):
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{NAME}: fmpy.simulate_fmu, pretension then shear")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
