"""Run any scene or FMU through fmpy, with plots and a ParaView series:

    python -m velarium.run SCENE.json|MODEL.fmu [--out DIR] [--fmu-dir DIR]

A scene is packed into an FMU first (``--fmu-dir``, default build/fmus). Every input is ramped
from its start value to its max (10x start, or 1.0, when it declares no max) over the default
experiment, extended by one step so that the last recorded row carries the ramp's last value
(the one-step lag, docs/fmu.md). It prints the table (time, the loads each row carries, the
outputs) and writes into build/runs/<Name>/ (or --out DIR):

    <Name>.png           load-response plot (every output against the first input)
    <Name>_3d.png        the deformed shape at the last load in 3-D, coloured by wrinkle
                         state and by the major principal stress, cables drawn
    vtk/<Name>.pvd       the ParaView series (vtk/<Name>_NNNN.vtu per load row), written by
                         `velarium solve --vtk` on the same table; solve.csv and
                         elements.csv beside it

fmpy sets u(t_k) before DoStep(t_k, h) and records after it, so the row at t_{k+1} is the
equilibrium under u(t_k). The table prints the load each row's equilibrium carries.
Needs matplotlib (pip install velarium[plots]).
"""

from __future__ import annotations

import argparse
import os
import sys
import zipfile
from pathlib import Path

import fmpy
import numpy as np

from . import tables as vr
from .engine import VelariumError, pack, series_files, write_vtk_series
from .paraview import mesh_of, read_vtu, write_series
from .fmu import RunEndedEarly, simulate
from .tables import carried_loads

STATE_COLOURS = {0: "#4c9be8", 1: "#f0a030", 2: "#d0d0d0"}
STATE_NAMES = {0: "taut", 1: "wrinkled", 2: "slack"}


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
    """Every output against the load the row carries (the first input)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    load = vr.inputs(md)[0].name
    x = carried_loads(table, load)[: len(rows)]
    outputs = [v.name for v in vr.outputs(md)]
    columns = min(4, len(outputs))
    lines = -(-len(outputs) // columns)
    fig, axes = plt.subplots(lines, columns, figsize=(4.2 * columns, 3.6 * lines), squeeze=False)
    for ax in axes.flat[len(outputs):]:
        ax.set_visible(False)
    for ax, name in zip(axes.flat, outputs):
        ax.plot(x, rows[name], "o-")
        ax.set_xlabel(f"{load} [{unit(md, load)}]")
        ax.set_ylabel(f"{name} [{unit(md, name)}]")
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{md.modelName}: fmpy.simulate_fmu, quasi-static load ramp")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_3d(vtu: Path, path: Path, title: str) -> None:
    """The deformed shape of one .vtu in 3-D: triangles coloured by wrinkle state (left) and by
    the major principal Cauchy stress (right), cable segments drawn in black."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    mesh = read_vtu(vtu)
    points = mesh.points + mesh.point_data["displacement_m"]  # the file's points are the reference
    is_tri, is_line = mesh.types == 5, mesh.types == 3
    fields = {name: {"triangle": values[is_tri]} for name, values in mesh.cell_data.items()}
    # Triangles come first, then the cable segments (docs/scenes.md).
    tris = mesh.connectivity[: 3 * is_tri.sum()].reshape(-1, 3)
    lines = mesh.connectivity[3 * is_tri.sum():].reshape(-1, 2) if is_line.any() else np.zeros((0, 2), int)
    fig = plt.figure(figsize=(13, 5.6))
    span = np.ptp(points, axis=0).max() or 1.0
    centre = (points.max(axis=0) + points.min(axis=0)) / 2
    panels = [("wrinkle state", None), ("major principal stress [Pa]", "sigma_max_Pa")]
    for k, (label, field) in enumerate(panels):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        if len(tris):
            if field is None:
                states = fields["wrinkle_state"]["triangle"].astype(int)
                colours = [STATE_COLOURS[s] for s in states]
                ax.legend(handles=[Patch(color=STATE_COLOURS[s], label=f"{STATE_NAMES[s]} ({np.sum(states == s)})") for s in STATE_NAMES], loc="upper left", fontsize=8)
            else:
                values = fields[field]["triangle"]
                # Clipped at the 98th percentile: support corners concentrate stress in a few
                # triangles and would leave the rest of the sheet in one colour.
                top = float(np.percentile(values, 98))
                norm = matplotlib.colors.Normalize(vmin=float(np.min(values)), vmax=top)
                label = f"{label}, clipped at {top:.3g} (98th percentile; max {float(np.max(values)):.3g})"
                colours = matplotlib.cm.viridis(norm(values))
                fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap="viridis"), ax=ax, shrink=0.6, label=label)
            ax.add_collection3d(Poly3DCollection(points[tris], facecolors=colours, edgecolors="none", linewidths=0))
        if len(lines):
            ax.add_collection3d(Line3DCollection(points[lines], colors="black", linewidths=1.5))
        for axis, c in zip("xyz", centre):
            getattr(ax, f"set_{axis}lim")(c - span / 2, c + span / 2)
            getattr(ax, f"set_{axis}label")(f"{axis} [m]")
        ax.set_box_aspect((1, 1, 1))
        ax.set_title(label)
    fig.suptitle(title)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def series_of_rows(fmu: Path, rows: np.ndarray, directory: Path) -> Path | None:
    """The ParaView series of fmpy's rows (:mod:`velarium.paraview`) if the FMU's array outputs
    place every node and give principal stresses and wrinkle states (what plot_3d draws); None
    otherwise."""
    mesh = mesh_of(fmu)
    kinds = {key.partition(":")[0] for key in mesh.field_data}
    placed = set()
    for key, points in mesh.field_data.items():
        if key.startswith("displacement_field:"):
            placed.update(int(p) for p in points)
    if len(placed) < len(mesh.points) or not {"principal_stresses", "wrinkle_states"} <= kinds:
        return None
    return write_series(fmu, rows, directory)


def run_any(target: str | os.PathLike, out: str | os.PathLike | None = None, fmu_dir: str | os.PathLike | None = None) -> Path:
    """Run a scene or an FMU (see the module's docstring); returns the output directory. A scene
    is packed into ``fmu_dir`` (default ``build/fmus``) first."""
    target = Path(target)
    if target.suffix == ".fmu":
        if not target.is_file():
            raise ValueError(f"{target}: no such file")
        fmu = target
    else:
        fmu = pack(target, fmu_dir or Path("build") / "fmus", fmi=2)[0]
    md = fmpy.read_model_description(str(fmu))
    name = md.modelName
    out = Path(out) if out is not None else Path("build") / "runs" / name
    out.mkdir(parents=True, exist_ok=True)
    if not vr.inputs(md):
        raise ValueError(f"{target}: the scene has no inputs, so there is no load table to run")
    start, stop = vr.experiment(md)
    steps = round((stop - start) / float(md.defaultExperiment.stepSize))
    table = vr.ramp_table(md, steps)
    extended = vr.extend_by_one_step(table)
    rows = simulate(fmu, extended)
    print(f"\n{name}: {md.description}\n")
    print_table(rows, extended, md)
    plot(rows, extended, md, out / f"{name}.png")
    scene = out / f"{fmu.stem}.scene.json"
    with zipfile.ZipFile(fmu) as z:
        scene.write_bytes(z.read("resources/scene.json"))
    pvd = series_of_rows(fmu, rows, out / "vtk")
    if pvd is None:
        pvd = write_vtk_series(scene, table, out / "vtk")
    series = series_files(pvd)
    last_time, last_vtu = series[-1]
    loads = ", ".join(f"{v.name} = {format_cell(table[v.name][-1])} {unit(md, v.name)}" for v in vr.inputs(md))
    plot_3d(last_vtu, out / f"{name}_3d.png", f"{name} at {loads} (deformation true to scale)")
    for p in (out / f"{name}.png", out / f"{name}_3d.png", pvd):
        print(f"wrote {shown(p)}")
    print(f"  ({len(series)} .vtu files; open {pvd.name} in ParaView)")
    return out


def shown(p: Path) -> str:
    try:
        return str(p.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(p)


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(prog="python -m velarium.run", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("target", type=Path, help="a scene (.json) or an FMU (.fmu)")
    parser.add_argument("--out", type=Path, default=None, help="output directory (default: build/runs/<Name>)")
    parser.add_argument("--fmu-dir", type=Path, default=None, help="where a scene is packed (default: build/fmus)")
    args = parser.parse_args(argv)
    if not args.target.is_file():
        sys.exit(f"{args.target}: no such file")
    try:
        return run_any(args.target, args.out, args.fmu_dir)
    except (ValueError, VelariumError, RunEndedEarly, FileNotFoundError) as e:
        sys.exit(str(e))


if __name__ == "__main__":
    main()
