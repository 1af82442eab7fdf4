"""A headless pyvista picture of a ParaView series or one .vtu (what ParaView would show).

    .venv/bin/python harness/screenshot.py SERIES.pvd OUT.png [--scalars wrinkle_state] [--row -1] [--scale 1]

Draws the deformed membrane of one row (default: the last; the file's points are the reference
positions, warped here by `displacement_m` times --scale, 1 by default as ParaView's Warp By
Vector does) coloured by a cell field (`wrinkle_state` with taut/wrinkled/slack colours,
`sigma_max_Pa` in kPa or MPa, or any other) and the cables as tubes, off screen (no display
needed: VTK renders through EGL/OSMesa when there is no X server; harness/setup.sh installs the
system GL libraries if they are missing). The drawing is the package's (velarium.render, the
same as `python -m velarium.run`'s 3-D picture), one field.

Examples:
  .venv/bin/python harness/screenshot.py build/WindSquare/WindSquare.pvd build/plots/WindSquare_pyvista.png --scalars sigma_max_Pa
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import velarium_run as vr
from velarium.render import picture


def screenshot(source: Path, out: Path, scalars: str = "wrinkle_state", row: int = -1, title: str | None = None,
               scale: float = 1.0) -> Path:
    vtu = vr.series_files(source)[row][1] if source.suffix == ".pvd" else source
    picture(vtu, out, title or vtu.name, scale=scale, cut=None, fields=(scalars,))
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("source", type=Path, help="a .pvd series or one .vtu")
    parser.add_argument("out", type=Path, help="the PNG to write")
    parser.add_argument("--scalars", default="wrinkle_state", help="cell field to colour by (default: %(default)s)")
    parser.add_argument("--row", type=int, default=-1, help="row of a .pvd series (default: the last)")
    parser.add_argument("--scale", type=float, default=1.0, help="displacement scale factor (default: 1, true to scale)")
    args = parser.parse_args(argv)
    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    if not args.source.is_file():
        raise SystemExit(f"{args.source}: no such file (run `python -m velarium.run` or `velarium solve --vtk` first)")
    print(f"wrote {screenshot(args.source, args.out, args.scalars, args.row, scale=args.scale)}")


if __name__ == "__main__":
    main()
