"""The harness's view of the checkout: where the shipped scenes, the packed FMUs and the built
command are, over the `velarium` Python package (python/velarium, docs/python.md), which holds
the load tables, the fmpy runs and fmpy's resident logger.

A load table is a NumPy structured array: field ``time`` first, then one float field per FMU
input, exactly what ``fmpy.simulate_fmu(input=...)`` takes. The same table goes through
``velarium solve`` as CSV (``write_loads_csv``) so both runs see the same f64 values.

Timing (docs/fmu.md, "Stepping"): fmpy sets ``u(t_k)`` before ``DoStep(t_k, h)`` and records
after it, so its row at ``t_{k+1}`` is the equilibrium under ``u(t_k)``, which is ``velarium
solve``'s row ``k``; its row at ``t_0`` (read right after initialization) is solve's row 0 too.
The functions here take the binary explicitly (the checkout's target/release by default), so a
test always runs the build it names; the package's own functions run the bundled one.
"""

from __future__ import annotations

import json
import os
import subprocess
import zipfile
from pathlib import Path

import fmpy  # noqa: F401  (tests reach fmpy as vr.fmpy)
import numpy as np

from velarium.engine import series_files  # noqa: F401
from velarium.fmu import (  # noqa: F401
    TIMEOUT,
    register_resident_logger,
    set_resident_logger,
    simulate,
    simulate_fmu,
)
from velarium.tables import (  # noqa: F401
    carried_loads,
    experiment,
    extend_by_one_step,
    inputs,
    outputs,
    ramp_table,
    ramp_target,
    read_csv,
    write_loads_csv,
)

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


def shipped_models() -> list[str]:
    """Names of the shipped scenes: every modelDescription/<Name>/scene.json."""
    return sorted(p.parent.name for p in SCENES.glob("*/scene.json"))


def is_dynamic(model: str) -> bool:
    """Whether a shipped scene integrates in time (its `dynamics.time_integration`,
    docs/dynamics.md): its results depend on the communication steps, and it has no
    derivatives."""
    scene = json.loads((SCENES / model / "scene.json").read_text())
    return "time_integration" in (scene.get("dynamics") or {})


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


def fmu_member(fmu: Path, name: str) -> bytes:
    with zipfile.ZipFile(fmu) as z:
        return z.read(name)


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
