"""Helpers of the conformance suite (``test_conformance.py``): the low-level fmpy API with
explicit cleanup, a log recorder, debug variants of a shipped scene, and subprocess runs.

Log recording. fmpy's native logger proxy (``fmpy.logging.addLoggerProxy``) formats the FMU's
variadic message and forwards it to ONE process-wide Python callback: the last one registered.
This module makes one, kept alive for the life of the process, the resident callback of
``velarium_run`` (registered at import and again after every run that passes its own
``logger=``): it records every message *and prints it exactly as fmpy's default printer does*.
So the default callbacks of fmpy (which reach this callback too) keep their behaviour, and no
callback is ever garbage-collected while the native proxy still points at it. Pass ``logger=``
only through ``velarium_run.simulate_fmu`` / ``simulate``, never to ``fmpy.simulate_fmu``.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import subprocess
import sys
from ctypes import byref
from pathlib import Path

import fmpy
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy

import velarium_run as vr

HARNESS = Path(__file__).resolve().parent

LABELS = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"]

# (instanceName, status, category, message) of every FMU message since the last clear().
RECORDS: list[tuple[str, int, str, str]] = []
# Raw bytes of every message (or instance/category name) that was not valid UTF-8.
NOT_UTF8: list[bytes] = []


def _text(raw: bytes | None) -> str:
    if raw is None:
        return ""
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        NOT_UTF8.append(raw)
        return raw.decode("utf-8", errors="replace")


def _record(_env, instance_name, status, category, message):
    text = _text(message)
    RECORDS.append((_text(instance_name), status, _text(category), text))
    print(f"[{LABELS[status] if 0 <= status < len(LABELS) else status}] {text}")


_LOGGER = fmi2CallbackLoggerTYPE(_record)
vr.set_resident_logger(_LOGGER)
# The structure the harness instantiates with (its logger is the proxy; the proxy reaches
# _LOGGER while it is resident).
CALLBACKS = fmi2CallbackFunctions()
CALLBACKS.logger = _LOGGER
CALLBACKS.allocateMemory = fmpy.fmi2.defaultCallbacks.allocateMemory
CALLBACKS.freeMemory = fmpy.fmi2.defaultCallbacks.freeMemory
addLoggerProxy(byref(CALLBACKS))


def clear_log() -> None:
    RECORDS.clear()
    NOT_UTF8.clear()


def messages(status: int | None = None) -> list[str]:
    return [m for _, s, _, m in RECORDS if status is None or s == status]


OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3


def status_of(call, *args) -> int:
    """Call an fmpy FMU2Slave method and return its fmi2Status instead of raising."""
    try:
        call(*args)
    except FMICallException as e:
        return e.status
    return OK


_EXTRACTED: dict[tuple[Path, Path], Path] = {}


def extracted(fmu: Path, root: Path) -> Path:
    """The FMU unzipped once under ``root`` (reused by every test of the session)."""
    key = (fmu, root)
    if key not in _EXTRACTED:
        target = root / fmu.stem
        shutil.rmtree(target, ignore_errors=True)
        _EXTRACTED[key] = Path(fmpy.extract(str(fmu), str(target)))
    return _EXTRACTED[key]


@contextlib.contextmanager
def slave(unzipdir: Path, md, name: str = "instance", instantiate: bool = True, logging_on: bool = False, guid=None):
    """An FMU2Slave with the recording logger; always freed (instance and library)."""
    s = FMU2Slave(
        guid=md.guid if guid is None else guid,
        unzipDirectory=str(unzipdir),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName=name,
    )
    s.component = None
    try:
        if instantiate:
            s.instantiate(callbacks=CALLBACKS, loggingOn=logging_on)
        yield s
    finally:
        if s.component is not None:
            s.fmi2FreeInstance(s.component)
            s.component = None
        s.freeLibrary()


def initialize(s, md, start: float | None = None, stop: float | None = None, values: dict | None = None) -> None:
    """SetupExperiment, start values, Enter/ExitInitializationMode."""
    t0, t1 = vr.experiment(md)
    s.setupExperiment(startTime=t0 if start is None else start, stopTime=stop)
    s.enterInitializationMode()
    for name, value in (values or {}).items():
        s.setReal([vref(md, name)], [value])
    s.exitInitializationMode()


def vref(md, name: str) -> int:
    return next(v.valueReference for v in md.modelVariables if v.name == name)


def real_output_refs(md) -> list[int]:
    return [v.valueReference for v in vr.outputs(md) if v.type == "Real"]


def step_grid(md, steps: int) -> list[tuple[float, float]]:
    t0, t1 = vr.experiment(md)
    h = (t1 - t0) / steps
    return [(t0 + k * h, h) for k in range(steps)]


def ramp_run(s, md, steps: int, start_index: int = 0) -> list[list[float]]:
    """Drive every input along ``ramp_table`` with DoStep on the default grid; the Real outputs
    after initialization and after every step (the instance must be initialized)."""
    table = vr.ramp_table(md, steps)
    refs = real_output_refs(md)
    rows = [list(s.getReal(refs))]
    for k in range(start_index, steps):
        set_inputs(s, md, table[k])
        t = float(table["time"][k])
        s.doStep(t, float(table["time"][k + 1]) - t)
        rows.append(list(s.getReal(refs)))
    return rows


def set_inputs(s, md, row) -> None:
    ins = vr.inputs(md)
    if ins:
        s.setReal([v.valueReference for v in ins], [float(row[v.name]) for v in ins])


def debug_variant(model: str, directory: Path, velarium: Path, **debug: float) -> Path:
    """The shipped scene with a ``debug`` section (e.g. ``fail_after_time=0.5``), each switch
    also exposed as a tunable parameter ``debug_<field>``, packed into ``directory``."""
    scene = json.loads((vr.SCENES / model / "scene.json").read_text())
    # A test variant ships no reference results worth their cost: without the load history the
    # packer's reference run is the initial equilibrium held (about 5 s saved per set of packs).
    scene.get("experiment", {}).pop("loads", None)
    scene["debug"] = dict(debug)
    scene.setdefault("parameters", [])
    for field in debug:
        scene["parameters"].append({"name": f"debug_{field}", "target": f"debug.{field}", "variability": "tunable",
                                    "description": f"debug switch {field}"})
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "scene.json"
    path.write_text(json.dumps(scene, indent=1))
    run = subprocess.run([str(velarium), "pack", str(path), "--out", str(directory)], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"velarium pack failed:\n{run.stderr}")
    return directory / f"{scene['name']}.fmu"


def run_python(code: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter with the harness importable; the caller asserts on
    the exit status (a crash of the FMU shows up as a negative return code, e.g. -11 or -6)."""
    env = dict(os.environ, PYTHONPATH=str(HARNESS) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=timeout, env=env)


def rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS in /proc/self/status")


def open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def mappings_of(path: Path) -> int:
    text = Path("/proc/self/maps").read_text()
    return sum(1 for line in text.splitlines() if line.endswith(str(path)))
