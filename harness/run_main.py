"""The main job (README, "Two commands on a fresh machine"; run it through harness/main.sh).

1. Pack every shipped scene (modelDescription/<Name>/scene.json) into build/fmus/<Name>.fmu
   with target/release/velarium.
2. Default (SleeveCable, the seed paper's Table 1): calibrate the rubber's shear modulus and
   the sleeve friction to Table 1 through the FMU (harness/calibrate_sleeve.py), print our
   numbers beside the experiment and write build/plots/SleeveCable_table1.png and
   SleeveCable_deformed.png (harness/sleeve_table.py).
3. With --model NAME (another shipped scene): run a load history through fmpy, each input
   ramped from its start value to its max (10x start, or 1.0, when it declares no max) over
   the default experiment; print the table (time, loads, outputs) and write
   build/plots/<NAME>.png.

fmpy sets u(t_k) before DoStep(t_k, h) and records after it, so the row at t_{k+1} is the
equilibrium under u(t_k). The table prints the load each row's equilibrium carries.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import fmpy
import numpy as np

import velarium_run as vr

PLOTS = vr.ROOT / "build" / "plots"


def pack_all(binary: Path) -> list[Path]:
    vr.FMU_DIR.mkdir(parents=True, exist_ok=True)
    fmus = []
    for name in vr.shipped_models():
        scene = vr.SCENES / name / "scene.json"
        run = subprocess.run([str(binary), "pack", str(scene), "--out", str(vr.FMU_DIR)], capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"packing {scene} failed:\n{run.stderr}")
        fmus.append(Path(run.stdout.splitlines()[0]))  # the FMI 2 archive (the FMI 3 one follows)
        print(f"packed {fmus[-1].relative_to(vr.ROOT)}")
    return fmus


def carried_loads(table: np.ndarray, name: str) -> np.ndarray:
    """The load under which each recorded row is in equilibrium: u(t_0), then u(t_k) at t_{k+1}."""
    u = table[name]
    return np.concatenate([u[:1], u[:-1]])


def print_table(rows: np.ndarray, table: np.ndarray, md) -> None:
    inputs = [v.name for v in vr.inputs(md)]
    outputs = [v.name for v in vr.outputs(md)]
    loads = {n: carried_loads(table, n) for n in inputs}
    header = ["time"] + [f"{n} [{unit(md, n)}]" for n in inputs] + [f"{n} [{unit(md, n)}]" for n in outputs]
    widths = [max(12, len(h)) for h in header]
    print("  ".join(h.rjust(w) for h, w in zip(header, widths)))
    for k, row in enumerate(rows):
        cells = [row["time"]] + [loads[n][k] for n in inputs] + [row[n] for n in outputs]
        print("  ".join(format_cell(c).rjust(w) for c, w in zip(cells, widths)))


def unit(md, name: str) -> str:
    v = next(v for v in md.modelVariables if v.name == name)
    return v.unit or "-"


def format_cell(x) -> str:
    return str(int(x)) if isinstance(x, (int, np.integer)) else f"{float(x):.6g}"


def plot(rows: np.ndarray, table: np.ndarray, md, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    load = vr.inputs(md)[0].name
    x = carried_loads(table, load)
    outputs = [v.name for v in vr.outputs(md)]
    fig, axes = plt.subplots(1, len(outputs), figsize=(4.2 * len(outputs), 3.8), squeeze=False)
    for ax, name in zip(axes[0], outputs):
        ax.plot(x, rows[name], "o-")
        ax.set_xlabel(f"{load} [{unit(md, load)}]")
        ax.set_ylabel(f"{name} [{unit(md, name)}]")
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{md.modelName}: fmpy.simulate_fmu, quasi-static load ramp")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="SleeveCable", help="which packed scene to run (default: %(default)s)")
    parser.add_argument("--velarium", type=Path, default=vr.VELARIUM, help="the velarium binary")
    args = parser.parse_args()
    if not args.velarium.is_file():
        sys.exit(f"{args.velarium} is missing: run `cargo build --release` (or bash harness/main.sh)")

    fmus = pack_all(args.velarium)
    fmu = next((f for f in fmus if f.stem == args.model), None)
    if fmu is None:
        sys.exit(f"no shipped scene is named {args.model}: {[f.stem for f in fmus]}")
    if args.model == "SleeveCable":
        import calibrate_sleeve
        import sleeve_table

        calibrate_sleeve.main()
        sleeve_table.main([])
        return
    md = fmpy.read_model_description(str(fmu))
    start, stop = vr.experiment(md)
    steps = round((stop - start) / float(md.defaultExperiment.stepSize))
    table = vr.ramp_table(md, steps)
    rows = vr.simulate(fmu, table)
    print(f"\n{md.modelName}: {md.description}\n")
    print_table(rows, table, md)
    path = PLOTS / f"{md.modelName}.png"
    plot(rows, table, md, path)
    print(f"\nwrote {path.relative_to(vr.ROOT)}")


if __name__ == "__main__":
    main()
