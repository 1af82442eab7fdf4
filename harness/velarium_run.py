"""Shared pieces of the harness: where things are, load tables, and the two ways to run one.

A load table is a NumPy structured array: field ``time`` first, then one float field per FMU
input, exactly what ``fmpy.simulate_fmu(input=...)`` takes. The same table goes through
``velarium solve`` as CSV (``write_loads_csv``) so both runs see the same f64 values.

Timing (docs/fmu.md, "The one-step lag"): fmpy sets ``u(t_k)`` before ``DoStep(t_k, h)`` and records after it, so its
row at ``t_{k+1}`` is the equilibrium under ``u(t_k)``, which is ``velarium solve``'s row ``k``;
its row at ``t_0`` (read right after initialization) is solve's row 0 as well.
"""

from __future__ import annotations

import csv
import os
import subprocess
import zipfile
from pathlib import Path

import fmpy
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "modelDescription"
# The packed shipped scenes; VELARIUM_FMU_DIR points the harness at another set.
FMU_DIR = Path(os.environ.get("VELARIUM_FMU_DIR") or ROOT / "build" / "fmus").resolve()
VELARIUM = ROOT / "target" / "release" / "velarium"
# The native FMU library and its portable glibc 2.17 build (harness/portable.sh); `velarium pack`
# ships the portable one by default when it is not older than the native one.
NATIVE_LIBRARY = VELARIUM.with_name("libvelarium.so")
PORTABLE_LIBRARY = ROOT / "target" / "x86_64-unknown-linux-gnu" / "release" / "libvelarium.so"


def default_library() -> Path:
    """The library `velarium pack` ships without --lib and VELARIUM_LIB (src/pack.rs, choose_library)."""
    return PORTABLE_LIBRARY if portable_library_is_current() else NATIVE_LIBRARY


def portable_library_is_current() -> bool:
    """Whether `velarium pack` ships the portable library by default (src/pack.rs, choose_library)."""
    if not PORTABLE_LIBRARY.is_file():
        return False
    return not NATIVE_LIBRARY.is_file() or PORTABLE_LIBRARY.stat().st_mtime >= NATIVE_LIBRARY.stat().st_mtime

# Wall-clock limit of one simulate_fmu run in seconds: the guard against a master loop that
# does not advance (docs/fmu.md).
TIMEOUT = 300


# ----------------------------------------------------------------------------- fmpy's logger
#
# fmpy formats an FMU's variadic log message in a small native proxy (fmpy.logging,
# `addLoggerProxy`) that forwards it to ONE process-wide pointer: the Python callback of the
# last callback structure registered. `simulate_fmu(..., logger=f)` registers a ctypes thunk of
# `f` that lives only as long as that call; afterwards the proxy's pointer dangles, and the next
# FMU instance that logs through fmpy's default callbacks (FMU2Slave.instantiate() without
# callbacks, as harness/sweep.py does) jumps into freed memory: SIGSEGV inside fmi2DoStep or
# any call that logs (docs/fmu.md, "fmpy's logger"). The harness therefore keeps one resident
# callback registered for the life of the process and puts it back after every run that
# passed its own logger: `simulate_fmu` below is the only way the harness passes `logger=`.

from ctypes import byref  # noqa: E402

from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, printLogMessage  # noqa: E402
from fmpy.logging import addLoggerProxy  # noqa: E402

# The resident thunk (fmpy's own printer until set_resident_logger replaces it) and every
# callback structure ever registered: none is ever garbage-collected while the proxy may hold it.
_RESIDENT = [fmi2CallbackLoggerTYPE(printLogMessage)]
_REGISTERED: list = []


def register_resident_logger() -> None:
    """Point fmpy's native proxy at the resident callback again."""
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = _RESIDENT[0]
    callbacks.allocateMemory = fmpy.fmi2.defaultCallbacks.allocateMemory
    callbacks.freeMemory = fmpy.fmi2.defaultCallbacks.freeMemory
    addLoggerProxy(byref(callbacks))
    _REGISTERED.append(callbacks)


def set_resident_logger(thunk) -> None:
    """Make `thunk` (an fmi2CallbackLoggerTYPE kept alive by the caller, e.g. a module global)
    the callback every proxied log message reaches, from now on and after every run."""
    _RESIDENT[0] = thunk
    register_resident_logger()


def simulate_fmu(fmu, logger=None, **kwargs):
    """fmpy.simulate_fmu; with `logger`, the resident callback is registered again afterwards
    (also when the run raises), so no later instance reaches the run's freed thunk."""
    if logger is None:
        return fmpy.simulate_fmu(str(fmu), **kwargs)
    try:
        return fmpy.simulate_fmu(str(fmu), logger=logger, **kwargs)
    finally:
        register_resident_logger()



def shipped_models() -> list[str]:
    """Names of the shipped scenes: every modelDescription/<Name>/scene.json."""
    return sorted(p.parent.name for p in SCENES.glob("*/scene.json"))


def inputs(model_description) -> list:
    return [v for v in model_description.modelVariables if v.causality == "input"]


def outputs(model_description) -> list:
    return [v for v in model_description.modelVariables if v.causality == "output"]


def ramp_target(variable) -> float:
    """Where a ramp of this input ends: its max if declared, else 10x its start (1.0 if 0)."""
    if variable.max is not None:
        return float(variable.max)
    start = float(variable.start)
    return 10.0 * start if start != 0.0 else 1.0


def experiment(model_description) -> tuple[float, float]:
    e = model_description.defaultExperiment
    return float(e.startTime), float(e.stopTime)


def ramp_table(model_description, steps: int) -> np.ndarray:
    """Every input ramped linearly from its start to ``ramp_target`` over the default
    experiment, on the grid fmpy uses (``t_k = start + k * h``), ``steps + 1`` rows."""
    start, stop = experiment(model_description)
    h = (stop - start) / steps
    names = [v.name for v in inputs(model_description)]
    table = np.zeros(steps + 1, dtype=[("time", np.float64)] + [(n, np.float64) for n in names])
    for k in range(steps + 1):
        table["time"][k] = start + k * h
    for v in inputs(model_description):
        u0, u1 = float(v.start), ramp_target(v)
        table[v.name] = [u0 + (u1 - u0) * k / steps for k in range(steps + 1)]
    return table


def write_loads_csv(table: np.ndarray, path: Path) -> None:
    """The table as `velarium solve` reads it; repr() of a float round-trips exactly."""
    names = table.dtype.names
    with open(path, "w") as f:
        # A 2-D array element's name has a comma ("corners[1,3]"): quoted, as `solve` reads it.
        f.write(",".join(f'"{n}"' if "," in n else n for n in names) + "\n")
        for row in table:
            f.write(",".join(repr(float(row[n])) for n in names) + "\n")


def read_csv(path: Path) -> np.ndarray:
    """A CSV with a header line as a structured float array."""
    with open(path) as f:
        rows = list(csv.reader(f))
    header, data = rows[0], rows[1:]
    out = np.zeros(len(data), dtype=[(n, np.float64) for n in header])
    for i, row in enumerate(data):
        for n, cell in zip(header, row):
            out[n][i] = float(cell)
    return out


def solve(scene: Path, table: np.ndarray, workdir: Path, binary: Path = VELARIUM) -> np.ndarray:
    """Run the table through `velarium solve`; raises with its stderr if it fails."""
    loads = workdir / f"{scene.parent.name}-loads.csv"
    result = workdir / f"{scene.parent.name}-solve.csv"
    write_loads_csv(table, loads)
    run = subprocess.run(
        [str(binary), "solve", str(scene), "--loads", str(loads), "--out", str(result)],
        capture_output=True,
        text=True,
    )
    if run.returncode != 0:
        raise RuntimeError(f"velarium solve failed ({run.returncode}):\n{run.stderr}")
    return read_csv(result)


def simulate(fmu: Path, table: np.ndarray | None = None, **kwargs) -> np.ndarray:
    """simulate_fmu with the table's grid as communication grid and a timeout. Checks that the
    run reached its stop time: an FMU whose step does not converge returns fmi2Discard with
    Terminated true, and fmpy then ends the run early without raising."""
    if table is not None:
        kwargs.setdefault("input", table)
        kwargs.setdefault("start_time", float(table["time"][0]))
        kwargs.setdefault("stop_time", float(table["time"][-1]))
        kwargs.setdefault("output_interval", float(table["time"][1] - table["time"][0]))
    kwargs.setdefault("timeout", TIMEOUT)
    result = simulate_fmu(fmu, **kwargs)
    stop = kwargs.get("stop_time")
    if stop is None:
        stop = float(fmpy.read_model_description(str(fmu)).defaultExperiment.stopTime)
    end = float(result["time"][-1])
    if not np.isclose(end, stop, rtol=1e-12, atol=1e-12):
        raise AssertionError(
            f"{fmu.name}: the run ended at t = {end}, before stop_time = {stop}: a step did not "
            f"converge (fmi2Discard, Terminated) or timed out; the FMU's log above says which"
        )
    return result


def fmu_member(fmu: Path, name: str) -> bytes:
    with zipfile.ZipFile(fmu) as z:
        return z.read(name)


def extend_by_one_step(table: np.ndarray) -> np.ndarray:
    """The table with one more row, one step after the last, holding the last row's loads.

    The one-step lag of co-simulation (docs/fmu.md, "The one-step lag"): fmpy sets u(t_k)
    before DoStep(t_k, h) and records the outputs at t_{k+1}, so the row recorded at t_{k+1}
    is the equilibrium under u(t_k) and the last row of a table is never carried by any
    recorded row. Run the extended table (stop time one step later) and the last recorded row
    is the equilibrium under the last load of the original table: a ramp reaches its end.
    The step is the table's last time step (its only step on fmpy's uniform grid).
    """
    if len(table) < 2:
        raise ValueError("a load table needs at least two rows to know its step")
    h = float(table["time"][-1] - table["time"][-2])
    extra = table[-1:].copy()
    extra["time"][0] = float(table["time"][-1]) + h
    return np.concatenate([table, extra])


def carried_loads(table: np.ndarray, name: str) -> np.ndarray:
    """The load under which each row fmpy records is in equilibrium: u(t_0) at t_0, then
    u(t_k) at t_{k+1} (the one-step lag)."""
    u = table[name]
    return np.concatenate([u[:1], u[:-1]])


def fmu_for(path: Path, out_dir: Path = FMU_DIR, binary: Path = VELARIUM) -> Path:
    """An FMU for ``path``: the file itself if it is an ``.fmu``, else the scene packed into
    ``out_dir`` with ``velarium pack`` (its stderr raised if the scene is bad)."""
    path = Path(path)
    if path.suffix == ".fmu":
        return path
    out_dir.mkdir(parents=True, exist_ok=True)
    run = subprocess.run([str(binary), "pack", str(path), "--out", str(out_dir), "--fmi", "2"], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"velarium pack {path} failed ({run.returncode}):\n{run.stderr}")
    return Path(run.stdout.strip())


def scene_of(path: Path, workdir: Path) -> Path:
    """The scene file of a scene or of an FMU (its ``resources/scene.json``, copied into
    ``workdir``)."""
    path = Path(path)
    if path.suffix != ".fmu":
        return path
    scene = workdir / f"{path.stem}.scene.json"
    scene.write_bytes(fmu_member(path, "resources/scene.json"))
    return scene


def write_vtk_series(scene: Path, table: np.ndarray, directory: Path, binary: Path = VELARIUM) -> Path:
    """Run the table through ``velarium solve --vtk`` and return the ``.pvd`` it wrote into
    ``directory`` (one ``.vtu`` per row: row k is the equilibrium under row k's loads, which
    is fmpy's row at t_{k+1}). Also writes ``solve.csv`` and ``elements.csv`` there."""
    directory.mkdir(parents=True, exist_ok=True)
    loads = directory / "loads.csv"
    write_loads_csv(table, loads)
    run = subprocess.run(
        [str(binary), "solve", str(scene), "--loads", str(loads), "--out", str(directory / "solve.csv"),
         "--elements", str(directory / "elements.csv"), "--vtk", str(directory), "--quiet"],
        capture_output=True,
        text=True,
    )
    if run.returncode != 0:
        raise RuntimeError(f"velarium solve --vtk failed ({run.returncode}):\n{run.stderr}")
    pvd = sorted(directory.glob("*.pvd"))
    if len(pvd) != 1:
        raise RuntimeError(f"expected one .pvd in {directory}, found {pvd}")
    return pvd[0]


def series_files(pvd: Path) -> list[tuple[float, Path]]:
    """(time, .vtu path) of every data set of a .pvd collection, in file order."""
    import xml.etree.ElementTree as ET

    root = ET.parse(pvd).getroot()
    return [(float(d.get("timestep")), pvd.parent / d.get("file")) for d in root.iter("DataSet")]
