"""Run any scene or FMU through fmpy, with plots and a ParaView series:

    python -m velarium.run SCENE.json|MODEL.fmu [--loads LOADS.csv] [--out DIR] [--fmu-dir DIR]
        [--scale FACTOR] [--cut | --no-cut]

A scene is packed into an FMU first (``--fmu-dir``, default build/fmus). The load history is
``--loads``, a load table as `velarium solve --loads` reads it (a `time` column on a uniform
grid, then one column per input it sets; an input it does not name keeps its start value), or,
without it, every input ramped from its start value to its max (10x start, or 1.0, when it
declares no max) over the default experiment. The table is extended by one step so that the
last recorded row carries its last load (the one-step lag, docs/fmu.md). It prints the table
(time, the loads each row carries, the outputs) and writes into build/runs/<Name>/ (or --out):

    <Name>.png      every output against the input that varies (against time when several
                    vary, or none), with units
    <Name>_3d.png   the deformed shape at the last load in 3-D (pyvista, off screen): wrinkle
                    state and major principal stress (colour bar in kPa or MPa), cables drawn;
                    displacements drawn x FACTOR, stated in the picture (default: 1, or the
                    1-2-5 factor that shows the largest displacement as 10 % of the span when
                    it is smaller than 5 %); a two-sheet cushion is cut open along the vertical
                    plane y = y_centre so both sheets show (--cut/--no-cut force it)
    vtk/<Name>.pvd  the ParaView series (one .vtu per load row); solve.csv and elements.csv
                    beside it when `velarium solve --vtk` writes it

The pressure sign: a pressure input pushes along each triangle's normal, the side from which the
triangle's nodes run counter-clockwise. Generated meshes (rectangle, disc, annulus) are
counter-clockwise seen from above, so on a roof a positive pressure pushes the sheet up: wind
suction (uplift) is positive, wind pressing down on the roof is negative. It is not "negative is
suction": that holds only for a sheet whose normal points into the wind. docs/scenes.md, "Inputs".

fmpy sets u(t_k) before DoStep(t_k, h) and records after it, so the row at t_{k+1} is the
equilibrium under u(t_k). The table prints the load each row's equilibrium carries.
Needs matplotlib and pyvista (pip install velarium[plots]).

Examples:
  python -m velarium.run modelDescription/PrestressedCable/scene.json --loads examples/PrestressedCable-loads.csv --out build/runs/PrestressedCable
  python -m velarium.run modelDescription/ZonedCushion/scene.json --loads examples/ZonedCushion-loads.csv --scale 2
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
from .paraview import mesh_of, write_series
from .fmu import RunEndedEarly, simulate
from .tables import carried_loads



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


MAX_PANELS = 16


def varying_inputs(table: np.ndarray, md) -> list[str]:
    """The inputs whose carried load changes over the rows."""
    return [v.name for v in vr.inputs(md) if np.ptp(carried_loads(table, v.name)) > 0]


def plot(rows: np.ndarray, table: np.ndarray, md, path: Path) -> str:
    """Every output against the load the rows carry of the one input that varies, or against
    time when several inputs vary (or none). Returns the x-axis's name."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    varying = varying_inputs(table, md)
    if len(varying) == 1:
        load = varying[0]
        x = carried_loads(table, load)[: len(rows)]
        xlabel = f"{load} [{unit(md, load)}]"
        note = f"against {load}, the input that varies"
    else:
        load = "time"
        x = carried_loads(table, "time")[: len(rows)]  # the load table's time of the loads each row carries
        xlabel = "time of the load table's row [s]"
        note = (f"against time: {', '.join(varying)} vary" if varying else "against time: no input varies")
    # Scalar outputs only: an array output's elements (``u[1]``, ``u[2]``, ... hundreds of them on
    # a displacement field) belong in the 3-D picture and the series, not in one panel each.
    everything = [v.name for v in vr.outputs(md)]
    outputs = [n for n in everything if "[" not in n][:MAX_PANELS]
    if not outputs:
        outputs = everything[:MAX_PANELS]
    left = len(everything) - len(outputs)
    if left:
        note += f" ({left} array elements or further outputs not drawn: see the table and the series)"
    columns = min(4, len(outputs))
    lines = -(-len(outputs) // columns)
    fig, axes = plt.subplots(lines, columns, figsize=(4.2 * columns, 3.6 * lines), squeeze=False)
    for ax in axes.flat[len(outputs):]:
        ax.set_visible(False)
    for ax, name in zip(axes.flat, outputs):
        ax.plot(x, rows[name], "o-")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"{name} [{unit(md, name)}]")
        ax.grid(True, alpha=0.3)
    import textwrap

    title = f"{md.modelName}: fmpy.simulate_fmu, quasi-static, every output {note}"
    fig.suptitle("\n".join(textwrap.wrap(title, width=int(18 * 4.2 * columns))), fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return load


def plot_3d(vtu: Path, path: Path, title: str, scale: float | None = None, cut: bool | None = None) -> dict:
    """The deformed shape of one .vtu in 3-D (:func:`velarium.render.picture`: pyvista, off
    screen, the displacement scale factor and any cut stated in the picture)."""
    from .render import picture

    return picture(vtu, path, title, scale=scale, cut=cut)


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


def load_table(loads, md) -> np.ndarray:
    """A user's load table as a table over every input (an input it does not name keeps its start
    value), on a uniform grid; a bad table is a ValueError naming the column."""
    given = vr.as_table(loads)
    names = [v.name for v in vr.inputs(md)]
    for name in given.dtype.names[1:]:
        if name not in names:
            raise ValueError(f"loads.{name}: {md.modelName} has no input {name!r} (inputs: {names})")
    if len(given) < 2:
        raise ValueError("loads: a load table needs at least two rows (the step is their distance)")
    if not vr.is_uniform(given["time"]):
        raise ValueError("loads.time: fmpy steps on a uniform grid; the table's time steps differ: resample it, "
                         "or use `velarium solve`")
    table = np.zeros(len(given), dtype=[("time", np.float64)] + [(n, np.float64) for n in names])
    table["time"] = given["time"]
    for v in vr.inputs(md):
        table[v.name] = given[v.name] if v.name in given.dtype.names else float(v.start)
    return table


def run_any(target: str | os.PathLike, out: str | os.PathLike | None = None, fmu_dir: str | os.PathLike | None = None,
            loads=None, scale: float | None = None, cut: bool | None = None) -> Path:
    """Run a scene or an FMU (see the module's docstring); returns the output directory. A scene
    is packed into ``fmu_dir`` (default ``build/fmus``) first. ``loads``: a load table (anything
    :func:`velarium.as_table` takes, a CSV path among them); None ramps every input."""
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
    if loads is None:
        start, stop = vr.experiment(md)
        steps = round((stop - start) / float(md.defaultExperiment.stepSize))
        table = vr.ramp_table(md, steps)
    else:
        table = load_table(loads, md)
    extended = vr.extend_by_one_step(table)
    rows = simulate(fmu, extended)
    print(f"\n{name}: {md.description}\n")
    print_table(rows, extended, md)
    against = plot(rows, extended, md, out / f"{name}.png")
    scene = out / f"{fmu.stem}.scene.json"
    with zipfile.ZipFile(fmu) as z:
        scene.write_bytes(z.read("resources/scene.json"))
    pvd = series_of_rows(fmu, rows, out / "vtk")
    if pvd is None:
        pvd = write_vtk_series(scene, table, out / "vtk")
    series = series_files(pvd)
    last_time, last_vtu = series[-1]
    named = varying_inputs(extended, md) or [v.name for v in vr.inputs(md)]
    last = ", ".join(f"{n} = {format_cell(table[n][-1])} {unit(md, n)}" for n in named[:6])
    if len(named) > 6:
        last += f" and {len(named) - 6} more inputs"
    drawn = plot_3d(last_vtu, out / f"{name}_3d.png", f"{name} at {last}", scale=scale, cut=cut)
    print(f"wrote {shown(out / f'{name}.png')} (every output against {against})")
    how = f"displacements x{drawn['scale']:g}, largest true displacement {drawn['largest']:.3g} m"
    print(f"wrote {shown(out / f'{name}_3d.png')} ({how}{'; cut open to show both sheets' if drawn['cut'] else ''})")
    print(f"wrote {shown(pvd)}")
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
    add_run_options(parser)
    args = parser.parse_args(argv)
    if not args.target.is_file():
        sys.exit(f"{args.target}: no such file")
    try:
        return run_any(args.target, args.out, args.fmu_dir, loads=args.loads, scale=args.scale, cut=args.cut)
    except (ValueError, VelariumError, RunEndedEarly, FileNotFoundError) as e:
        sys.exit(str(e))


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """--loads, --scale, --cut/--no-cut (shared with harness/run_main.py)."""
    parser.add_argument("--loads", type=Path, default=None,
                        help="a load table (CSV: time, then the inputs it sets; default: every input ramped to its max)")
    parser.add_argument("--scale", type=float, default=None,
                        help="displacement scale factor of the 3-D picture (default: 1, or larger for small displacements)")
    cut = parser.add_mutually_exclusive_group()
    cut.add_argument("--cut", dest="cut", action="store_true", default=None,
                     help="cut the 3-D picture open along y = y_centre (default: when two sheets cover the plan)")
    cut.add_argument("--no-cut", dest="cut", action="store_false", help="never cut the 3-D picture open")


if __name__ == "__main__":
    main()
