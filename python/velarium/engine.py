"""The `velarium` command from Python: check and load scenes, solve load histories, pack FMUs,
write ParaView series. Every function runs the bundled command (see :mod:`velarium._locate`) and
raises :class:`VelariumError` with the command's own message when it fails."""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Mapping, Union

import numpy as np

from . import _locate
from .tables import LoadsLike, as_table, read_csv, write_loads_csv

SceneLike = Union[str, "os.PathLike[str]", Mapping[str, Any], "Scene"]


class VelariumError(RuntimeError):
    """A `velarium` command failed; ``problems`` are its message lines (a scene's problems by
    JSON path, a load table's by row and column)."""

    def __init__(self, message: str, problems: list[str] | None = None, returncode: int | None = None,
                 rows: np.ndarray | None = None):
        super().__init__(message)
        self.problems = problems or []
        self.returncode = returncode
        #: solve's rows before a step that did not converge (None for other failures).
        self.rows = rows


def _run(args: list[str], what: str) -> subprocess.CompletedProcess:
    run = subprocess.run([str(_locate.command()), *args], capture_output=True, text=True)
    if run.returncode != 0:
        lines = [line for line in (run.stdout + run.stderr).splitlines() if line.strip()]
        raise VelariumError(f"{what} failed (exit {run.returncode}):\n" + "\n".join(lines), lines, run.returncode)
    return run


@dataclass
class Scene:
    """A scene that `velarium check` accepted.

    ``path`` is its file (None for a scene given as a dict); ``data`` the parsed JSON; ``inputs``, ``outputs`` and ``parameters`` the names the FMU
    will have; ``summary`` check's ``ok:`` line and ``warnings`` its plausibility warnings."""

    path: Path | None
    data: dict
    summary: str
    warnings: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return str(self.data["name"])

    @property
    def inputs(self) -> list[str]:
        return [i["name"] for i in self.data.get("inputs", [])]

    @property
    def outputs(self) -> list[str]:
        return [o["name"] for o in self.data.get("outputs", [])]

    @property
    def parameters(self) -> list[str]:
        return [p["name"] for p in self.data.get("parameters", [])]

    @property
    def experiment(self) -> dict:
        return dict(self.data.get("experiment", {}))


def _scene_path(scene: SceneLike, workdir: Path) -> Path:
    if isinstance(scene, Scene):
        if scene.path is not None:
            return scene.path
        scene = scene.data
    if isinstance(scene, Mapping):
        path = workdir / f"{scene.get('name', 'scene')}.json"
        path.write_text(json.dumps(scene))
        return path
    path = Path(scene)
    if not path.is_file():
        raise ValueError(f"scene: {path}: no such file")
    return path


def load_scene(scene: SceneLike) -> Scene:
    """Read and check a scene (a path, or the scene as a dict). Every problem `velarium check`
    finds is raised at once as a :class:`VelariumError` whose ``problems`` name the JSON path
    (``cables[0].EA: -5 is not a positive axial stiffness in N ...``)."""
    if isinstance(scene, Scene):
        return scene
    with tempfile.TemporaryDirectory(prefix="velarium-") as tmp:
        path = _scene_path(scene, Path(tmp))
        run = subprocess.run([str(_locate.command()), "check", str(path)], capture_output=True, text=True)
        lines = [line for line in run.stdout.splitlines() if line.strip()]
        if run.returncode != 0:
            problems = lines or [line for line in run.stderr.splitlines() if line.strip()]
            raise VelariumError(f"scene {path if not isinstance(scene, Mapping) else scene.get('name', '')}: "
                                f"{len(problems)} problem(s):\n" + "\n".join(problems), problems, run.returncode)
        data = json.loads(path.read_text()) if not isinstance(scene, Mapping) else dict(scene)
    summary = next((line for line in lines if line.startswith("ok:")), "")
    warnings = [line for line in lines + run.stderr.splitlines() if line.startswith("warning")]
    return Scene(path=None if isinstance(scene, Mapping) else Path(path), data=data, summary=summary, warnings=warnings)


def solve(scene: SceneLike, loads: LoadsLike, *, vtk: str | os.PathLike | None = None,
          elements: str | os.PathLike | None = None, threads: int | None = None) -> np.ndarray:
    """Run a load history without an FMI master (`velarium solve`).

    Row k of the result (``time`` and every output) is the equilibrium under row k's loads,
    reached from row k-1's; a step that does not converge raises :class:`VelariumError` whose
    ``rows`` are the rows before it. ``loads`` is a table (structured array, dict of columns, DataFrame)
    or the path of a load CSV, given to the command as it is (load combinations included:
    docs/cli.md). ``vtk=DIR`` also writes the ParaView series ``DIR/<name>.pvd``,
    ``elements=FILE`` the per-triangle CSV."""
    table = None if isinstance(loads, (str, os.PathLike)) else as_table(loads)
    if threads is not None and (int(threads) != threads or not 1 <= threads <= 64):
        raise ValueError(f"threads: {threads!r} is not a whole number from 1 to 64")
    with tempfile.TemporaryDirectory(prefix="velarium-") as tmp:
        tmp = Path(tmp)
        path = _scene_path(scene, tmp)
        csv_in, csv_out = tmp / "loads.csv", tmp / "result.csv"
        if table is None:
            csv_in = Path(loads)
            if not csv_in.is_file():
                raise ValueError(f"loads: {csv_in}: no such file")
        else:
            _check_columns(path, table)
            write_loads_csv(table, csv_in)
        args = ["solve", str(path), "--loads", str(csv_in), "--out", str(csv_out), "--quiet"]
        if vtk is not None:
            args += ["--vtk", str(vtk)]
        if elements is not None:
            args += ["--elements", str(elements)]
        if threads is not None:
            args += ["--threads", str(int(threads))]
        try:
            _run(args, f"velarium solve {path.name}")
        except VelariumError as e:
            if csv_out.is_file():
                e.rows = read_csv(csv_out)
            raise
        return read_csv(csv_out)


def _check_columns(path: Path, table: np.ndarray) -> None:
    """Every column of a load table names an input (a scene file that does not parse is left to
    the command, which names what is wrong with it)."""
    try:
        data = json.loads(path.read_text())
        names = {i["name"] for i in data.get("inputs", [])}
    except (OSError, ValueError, TypeError, KeyError):
        return
    for name in table.dtype.names[1:]:
        if name not in names:
            raise ValueError(f"loads.{name}: {data.get('name', path.name)} has no input {name!r} (inputs: {sorted(names)})")


def pack(scene: SceneLike, out: str | os.PathLike = ".", *, fmi: Literal[2, 3, "both"] = "both") -> list[Path]:
    """Pack a scene into FMUs in directory ``out`` (`velarium pack`): the FMI 2.0 archive
    ``<Name>.fmu`` and/or the FMI 3.0 one ``<Name>_fmi3.fmu``; returns their paths."""
    if fmi not in (2, 3, "both"):
        raise ValueError(f"fmi: {fmi!r} is not 2, 3 or 'both'")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="velarium-") as tmp:
        path = _scene_path(scene, Path(tmp))
        args = ["pack", str(path), "--out", str(out), "--lib", str(_locate.library())]
        if fmi != "both":
            args += ["--fmi", str(fmi)]
        run = _run(args, f"velarium pack {path.name}")
    return [Path(line) for line in run.stdout.splitlines() if line.strip()]


def write_vtk_series(scene: SceneLike, loads: LoadsLike, directory: str | os.PathLike) -> Path:
    """The ParaView series of a load history, written by `velarium solve --vtk` into
    ``directory`` (one ``.vtu`` per row: row k is the equilibrium under row k's loads, which is
    fmpy's row at t_{k+1}); also ``solve.csv`` and ``elements.csv`` there. Returns the ``.pvd``.

    Series from an FMU's array outputs (no second solve) are not in the package yet: see
    docs/python.md, "ParaView series"."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    table = as_table(loads)
    with tempfile.TemporaryDirectory(prefix="velarium-") as tmp:
        path = _scene_path(scene, Path(tmp))
        _check_columns(path, table)
        write_loads_csv(table, directory / "loads.csv")
        _run(["solve", str(path), "--loads", str(directory / "loads.csv"), "--out", str(directory / "solve.csv"),
              "--elements", str(directory / "elements.csv"), "--vtk", str(directory), "--quiet"],
             f"velarium solve --vtk {path.name}")
    pvd = sorted(directory.glob("*.pvd"))
    if len(pvd) != 1:
        raise VelariumError(f"expected one .pvd in {directory}, found {[p.name for p in pvd]}")
    return pvd[0]


# The second ParaView writer, a series from an FMU run's array outputs (no second solve), is
# velarium.paraview.write_series (exported as velarium.write_fmu_series).


def series_files(pvd: str | os.PathLike) -> list[tuple[float, Path]]:
    """(time, .vtu path) of every data set of a .pvd collection, in file order."""
    import xml.etree.ElementTree as ET

    pvd = Path(pvd)
    root = ET.parse(pvd).getroot()
    return [(float(d.get("timestep")), pvd.parent / d.get("file")) for d in root.iter("DataSet")]


def schema() -> dict:
    """The JSON Schema of the scene format (`velarium schema`)."""
    return json.loads(_run(["schema"], "velarium schema").stdout)
