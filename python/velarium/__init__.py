"""Velarium from Python: cable-reinforced membranes as scenes, load histories, FMUs and sweeps.

    import velarium

    scene = velarium.load_scene("tiny.json")           # check it: problems by JSON path
    rows = velarium.solve(scene, {"time": [0, 0.5, 1], "F": [0, 50, 100]})
    fmu, fmu3 = velarium.pack(scene, "build/fmus")       # FMI 2.0 and 3.0 archives
    same = velarium.run_fmu(fmu, {"time": [0, 0.5, 1], "F": [0, 50, 100]})  # lag handled
    result = velarium.sweep.sweep(fmu, {"F": [50, 100]}, scheduler="synchronous")
    master = velarium.couple.Master({"a": fmu, "b": "other.fmu"}, [["a.w", "b.w"], ["b.F", "a.F"]])
    pvd = velarium.write_vtk_series(scene, {"time": [0, 1], "F": [0, 100]}, "build/vtk")

Load tables and results are NumPy structured arrays (``to_pandas`` for a DataFrame). The
`velarium` command and ``libvelarium.so`` come with the wheel (:func:`command`,
:func:`library`; ``VELARIUM_HOME`` overrides). Documentation: docs/python.md.
"""

from __future__ import annotations

from ._locate import binaries_dir, command, library
from .engine import Scene, VelariumError, load_scene, pack, schema, series_files, solve, write_vtk_series
from .fmu import RunEndedEarly, run_fmu, simulate
from .paraview import read_vtu
from .paraview import write_series as write_fmu_series
from .tables import as_table, carried_loads, extend_by_one_step, ramp_table, read_csv, to_pandas, write_loads_csv

__version__ = "0.1.0"


def __getattr__(name: str):
    # velarium.sweep (Dask), velarium.run (matplotlib) and velarium.couple (the coupling master,
    # docs/coupling.md) are imported on first use, so that `import velarium` needs neither and
    # `python -m velarium.sweep` runs the module once.
    if name in ("sweep", "run", "couple"):
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'velarium' has no attribute {name!r}")


__all__ = [
    "RunEndedEarly", "Scene", "VelariumError", "as_table", "binaries_dir", "carried_loads", "command",
    "extend_by_one_step", "library", "load_scene", "pack", "ramp_table", "read_csv", "run_fmu", "schema",
    "read_vtu", "series_files", "simulate", "solve", "to_pandas", "write_fmu_series", "write_loads_csv",
    "write_vtk_series",
]
