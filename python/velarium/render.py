"""3-D pictures of one solved state (a .vtu of a ParaView series), drawn off screen with pyvista.

    picture(vtu, out_png, title, scale=None, cut=None, fields=("wrinkle_state", "sigma_max_Pa"))

One panel per cell field, side by side: ``wrinkle_state`` in taut/wrinkled/slack colours, a
stress field (``sigma_max_Pa``, ``sigma_min_Pa``) in kPa or MPa (whichever keeps the numbers
between 0.1 and 1000) with the unit on the colour bar, any other field as it is. Cables are
drawn as black tubes.

- **Displacement scale factor.** The file's points are the reference positions; the picture
  warps them by ``displacement_m`` times the factor. ``scale=None`` picks it: 1 when the
  largest displacement is at least 5 % of the structure's span, else the 1-2-5 number that
  shows it as about 10 % of the span (a 0.1 m bulge on a 10 m roof is drawn x10). The factor
  and the largest true displacement are printed in the picture's title, always.
- **Both sheets of a cushion.** When the membrane covers its plan more than once (the summed
  plan area of its triangles is more than 1.5 times the area of its plan's convex hull: a
  two-sheet cushion, a closed bag), the picture is **cut open**: the half beyond the vertical
  plane through the centre (y > y_centre) is removed, and the camera looks at the cut, so the
  top and the bottom sheet and the gap between them show in section. ``cut=True``/``False``
  forces it either way. The title says when a picture is cut.

Needs pyvista (pip install velarium[plots]). Without a display VTK renders through EGL (or
OSMesa); the harness's setup installs the system GL libraries if they are missing.
"""

from __future__ import annotations

import math
import os
import textwrap
from pathlib import Path

import numpy as np

STATE_COLOURS = ["#4c9be8", "#f0a030", "#d0d0d0"]  # taut, wrinkled, slack
STATE_NAMES = ["taut", "wrinkled", "slack"]


def scale_factor(displacement: np.ndarray, points: np.ndarray) -> float:
    """1 if the largest displacement is at least 5 % of the span, else the 1-2-5 number nearest
    below the one that draws it as 10 % of the span."""
    span = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    largest = float(np.linalg.norm(displacement, axis=1).max()) if len(displacement) else 0.0
    if span == 0.0 or largest == 0.0 or largest >= 0.05 * span:
        return 1.0
    wanted = 0.1 * span / largest
    decade = 10.0 ** math.floor(math.log10(wanted))
    return max(m * decade for m in (1, 2, 5) if m * decade <= wanted)


def stress_unit(values: np.ndarray) -> tuple[str, float]:
    """kPa or MPa (or Pa below 100 Pa) for a stress field: the unit and the divisor from Pa."""
    top = float(np.max(np.abs(values))) if len(values) else 0.0
    if top >= 1e5:
        return "MPa", 1e6
    if top >= 1e2:
        return "kPa", 1e3
    return "Pa", 1.0


def covers_plan_twice(points: np.ndarray, triangles: np.ndarray) -> bool:
    """Whether the triangles cover their plan (x, y) more than once: summed plan area > 1.5 x
    the area of the plan's convex hull."""
    if len(triangles) == 0:
        return False
    p = points[:, :2]
    a, b, c = p[triangles[:, 0]], p[triangles[:, 1]], p[triangles[:, 2]]
    plan = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])).sum()
    used = p[np.unique(triangles)]
    try:
        from scipy.spatial import ConvexHull

        hull = ConvexHull(used).volume  # in 2-D, volume is the area
    except Exception:  # degenerate (all points on a line): no plan to cover
        return False
    return bool(hull > 0 and plan > 1.5 * hull)


def _pyvista():
    if not os.environ.get("DISPLAY"):
        # No X server: let VTK open an EGL window directly instead of failing over from X.
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    return pv


def picture(vtu: str | os.PathLike, out: str | os.PathLike, title: str = "", scale: float | None = None,
            cut: bool | None = None, fields: tuple[str, ...] = ("wrinkle_state", "sigma_max_Pa")) -> dict:
    """Draw ``vtu`` into ``out`` (PNG); returns what was drawn: ``scale``, ``cut``, ``largest``
    (m, the largest true displacement), ``units`` (field -> unit of its colour bar)."""
    pv = _pyvista()
    vtu, out = Path(vtu), Path(out)
    grid = pv.read(str(vtu))
    if "displacement_m" not in grid.point_data:
        raise ValueError(f"{vtu}: no point field displacement_m (not a velarium series file?)")
    u = np.asarray(grid.point_data["displacement_m"])
    factor = scale_factor(u, np.asarray(grid.points)) if scale is None else float(scale)
    if not (factor > 0 and math.isfinite(factor)):
        raise ValueError(f"scale: {scale!r} is not a positive displacement scale factor")
    kind = np.asarray(grid.cell_data["kind"]) if "kind" in grid.cell_data else np.zeros(grid.n_cells, int)
    warped = grid.warp_by_vector("displacement_m", factor=factor)
    membrane = warped.extract_cells(np.flatnonzero(kind == 0))
    cables = warped.extract_cells(np.flatnonzero(kind == 1))
    if cut is None:
        deformed = np.asarray(grid.points) + u
        tris = _triangles(grid, kind)
        cut = covers_plan_twice(deformed, tris)
    centre = np.asarray(warped.center)
    if cut:
        membrane = membrane.clip(normal="y", origin=centre, invert=True) if membrane.n_cells else membrane
        cables = cables.clip(normal="y", origin=centre, invert=True) if cables.n_cells else cables
    largest = float(np.linalg.norm(u, axis=1).max()) if len(u) else 0.0
    shown = [f for f in fields if f in grid.cell_data] or ["kind"]
    plotter = pv.Plotter(off_screen=True, shape=(1, len(shown)), window_size=(max(1200, 760 * len(shown)), 760), border=False)
    units: dict[str, str] = {}
    how = f"displacements x{factor:g} (largest true displacement {largest:.3g} m)"
    if cut:
        how += f"; cut open at y = {centre[1]:.3g} m (the y > {centre[1]:.3g} m half removed) to show both sheets"
    for k, field in enumerate(shown):
        label = field
        plotter.subplot(0, k)
        bar = {"title_font_size": 18, "label_font_size": 16, "vertical": False, "width": 0.6,
               "position_x": 0.2, "position_y": 0.04, "n_labels": 5}
        if membrane.n_cells:
            if field == "wrinkle_state":
                states = np.asarray(grid.cell_data[field])[kind == 0].astype(int)
                counts = ", ".join(f"{n} {int(np.sum(states == s))}" for s, n in enumerate(STATE_NAMES))
                plotter.add_mesh(membrane, scalars=field, cmap=STATE_COLOURS, clim=(-0.5, 2.5), preference="cell",
                                 annotations={float(s): n for s, n in enumerate(STATE_NAMES)},
                                 scalar_bar_args={**bar, "title": "wrinkle state", "n_labels": 0})
                label = f"wrinkle state (triangles: {counts})"
                units[field] = "-"
            elif field.endswith("_Pa"):
                values = np.asarray(membrane.cell_data[field])
                unit, divisor = stress_unit(values)
                membrane.cell_data[f"{field}_shown"] = values / divisor
                name = field[: -len("_Pa")].replace("sigma_max", "major principal stress").replace("sigma_min", "minor principal stress")
                # The colours stop at the 98th percentile: support corners concentrate stress in a
                # few triangles and would leave the rest of the sheet in one colour.
                low, top = float(values.min()) / divisor, float(np.percentile(values, 98)) / divisor
                plotter.add_mesh(membrane, scalars=f"{field}_shown", cmap="viridis", preference="cell",
                                 clim=(low, max(top, low + 1e-12)), above_color="magenta",
                                 scalar_bar_args={**bar, "title": f"{name} [{unit}]", "fmt": "%.3g"})
                label = (f"{name} [{unit}], max {values.max() / divisor:.3g} {unit}\n"
                         f"colours stop at the 98th percentile, {top:.3g} {unit}; above: magenta")
                units[field] = unit
            else:
                plotter.add_mesh(membrane, scalars=field, cmap="viridis", preference="cell",
                                 scalar_bar_args={**bar, "title": field})
                label = field
                units[field] = ""
        if cables.n_cells:
            plotter.add_mesh(cables, color="black", line_width=4, render_lines_as_tubes=True)
        plotter.view_isometric()
        plotter.camera.elevation = plotter.camera.elevation - 12  # lower: the bulge shows against the sky
        head = textwrap.wrap(title, 90) + textwrap.wrap(how, 90) if k == 0 else []
        plotter.add_text("\n".join(head + [label]), position="upper_left", font_size=9)
    out.parent.mkdir(parents=True, exist_ok=True)
    plotter.screenshot(str(out))
    plotter.close()
    return {"scale": factor, "cut": bool(cut), "largest": largest, "units": units}


def _triangles(grid, kind: np.ndarray) -> np.ndarray:
    """The membrane triangles' point indices (the series writes triangles first)."""
    cells = np.asarray(grid.cells)
    tris = []
    i = 0
    for k in range(grid.n_cells):
        n = int(cells[i])
        if kind[k] == 0 and n == 3:
            tris.append(cells[i + 1: i + 4])
        i += n + 1
    return np.asarray(tris, dtype=int).reshape(-1, 3)
