"""A headless pyvista picture of a ParaView series or one .vtu (what ParaView would show).

    .venv/bin/python harness/screenshot.py SERIES.pvd OUT.png [--scalars wrinkle_state] [--row -1]

Draws the deformed membrane of one row (default: the last; the file's points are the reference
positions, warped here by `displacement_m` at scale 1 as ParaView's Warp By Vector does) coloured
by a cell field (`wrinkle_state` with taut/wrinkled/slack colours, or any other, e.g.
`sigma_max_Pa`) and the cables as tubes, off screen (no display needed: VTK renders through EGL/OSMesa when there is no X
server; harness/setup.sh installs the system GL libraries if they are missing).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

import velarium_run as vr


def screenshot(source: Path, out: Path, scalars: str = "wrinkle_state", row: int = -1, title: str | None = None) -> Path:
    if not os.environ.get("DISPLAY"):
        # No X server: let VTK open an EGL window directly instead of failing over from X
        # with a warning.
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    vtu = vr.series_files(source)[row][1] if source.suffix == ".pvd" else source
    grid = pv.read(vtu).warp_by_vector("displacement_m", factor=1.0)
    membrane = grid.extract_cells(np.flatnonzero(grid.cell_data["kind"] == 0))
    cables = grid.extract_cells(np.flatnonzero(grid.cell_data["kind"] == 1))
    plotter = pv.Plotter(off_screen=True, window_size=(1200, 800))
    if membrane.n_cells:
        if scalars == "wrinkle_state":
            plotter.add_mesh(
                membrane, scalars=scalars, cmap=["#4c9be8", "#f0a030", "#d0d0d0"], clim=(-0.5, 2.5),
                scalar_bar_args={"title": "0 taut, 1 wrinkled, 2 slack", "n_labels": 3, "fmt": "%.0f"},
            )
        else:
            plotter.add_mesh(membrane, scalars=scalars, cmap="viridis", scalar_bar_args={"title": scalars})
    if cables.n_cells:
        plotter.add_mesh(cables, color="black", line_width=4, render_lines_as_tubes=True)
    plotter.add_text(title or vtu.name, font_size=10)
    plotter.view_isometric()
    out.parent.mkdir(parents=True, exist_ok=True)
    plotter.screenshot(str(out))
    plotter.close()
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("source", type=Path, help="a .pvd series or one .vtu")
    parser.add_argument("out", type=Path, help="the PNG to write")
    parser.add_argument("--scalars", default="wrinkle_state", help="cell field to colour by (default: %(default)s)")
    parser.add_argument("--row", type=int, default=-1, help="row of a .pvd series (default: the last)")
    args = parser.parse_args(argv)
    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    print(f"wrote {screenshot(args.source, args.out, args.scalars, args.row)}")


if __name__ == "__main__":
    main()
