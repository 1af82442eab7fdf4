"""What one fmi2DoStep costs when nothing changed (issue 15 item 4; docs/fmu.md, the cost of a
step). A benchmark that prints numbers, not a test.

    .venv/bin/python harness/step_cost.py [MODEL] [--loaded]

Packs MODEL (default PrestressedCable) with target/release/velarium, initializes it through
fmpy, then times in one process, with fmpy's low-level ctypes functions of the FMU's own
library (fmi2DoStep, fmi2SetReal, fmi2GetReal bound as fmpy binds them):

- velarium step:  fmi2DoStep with the input unchanged;
- velarium s+s+g: fmi2SetReal of the input to its current value, fmi2DoStep, fmi2GetReal of
  every output (what a master does each step);
- velarium moved: fmi2SetReal of a new input value (alternating by 0.1 %), fmi2DoStep (a real
  solve, handed to the worker thread), fmi2GetReal of every output;
- do-nothing:     the same calls, same ctypes signatures, into a C library compiled here whose
  functions only return fmi2OK (the floor of a ctypes-called FMU).

Each figure is the median over 7 rounds of N calls (wall time per call, and CPU time of the
process per call). --loaded runs two busy-loop processes (one per core) during the timing and
stops them after. The load average is printed with the numbers.
"""

from __future__ import annotations

import ctypes
import shutil
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import fmpy
from fmpy.fmi2 import FMU2Slave

ROOT = Path(__file__).resolve().parent.parent
NOTHING_C = r"""
typedef void* fmi2Component;
int fmi2DoStep(fmi2Component c, double t, double h, int no_set_prior) { return 0; }
int fmi2SetReal(fmi2Component c, const unsigned* vr, unsigned long n, const double* v) { return 0; }
int fmi2GetReal(fmi2Component c, const unsigned* vr, unsigned long n, double* v) { return 0; }
"""


def bind(lib):
    """fmi2DoStep / SetReal / GetReal with fmpy's argument types."""
    do_step = lib.fmi2DoStep
    do_step.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]
    do_step.restype = ctypes.c_int
    set_real = lib.fmi2SetReal
    set_real.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t, ctypes.POINTER(ctypes.c_double)]
    set_real.restype = ctypes.c_int
    get_real = lib.fmi2GetReal
    get_real.argtypes = set_real.argtypes
    get_real.restype = ctypes.c_int
    return do_step, set_real, get_real


def rounds(run, n: int, repeats: int = 7) -> tuple[float, float]:
    """Median wall and CPU microseconds per call of run(k) over `repeats` rounds of n calls."""
    walls, cpus = [], []
    k = 0
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        for _ in range(n):
            run(k)
            k += 1
        walls.append((time.perf_counter() - w0) / n * 1e6)
        cpus.append((time.process_time() - c0) / n * 1e6)
    return statistics.median(walls), statistics.median(cpus)


def main() -> None:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    loaded = "--loaded" in sys.argv
    model = args[0] if args else "PrestressedCable"
    work = Path(tempfile.mkdtemp(prefix="velarium-step-cost-"))
    velarium = ROOT / "target" / "release" / "velarium"
    scene = ROOT / "modelDescription" / model / "scene.json"
    subprocess.run([str(velarium), "pack", str(scene), "--out", str(work)], check=True, capture_output=True)
    fmu = work / f"{model}.fmu"
    md = fmpy.read_model_description(str(fmu))
    unzip = fmpy.extract(str(fmu), str(work / "x"))
    nothing = work / "nothing.so"
    (work / "nothing.c").write_text(NOTHING_C)
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-o", str(nothing), str(work / "nothing.c")], check=True)

    s = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
    s.instantiate()
    t0 = float(md.defaultExperiment.startTime or 0.0) if md.defaultExperiment else 0.0
    s.setupExperiment(startTime=float(t0))
    s.enterInitializationMode()
    s.exitInitializationMode()
    variables = md.modelVariables
    inp = next(v for v in variables if v.causality == "input")
    outs = [v.valueReference for v in variables if v.causality == "output" and v.type == "Real"]
    vr_in = (ctypes.c_uint * 1)(inp.valueReference)
    start = float(inp.start)
    value = (ctypes.c_double * 1)(start)
    vr_out = (ctypes.c_uint * len(outs))(*outs)
    got = (ctypes.c_double * len(outs))()
    h = 1e-3
    clock = {"t": t0}

    v_step, v_set, v_get = bind(s.dll)
    n_step, n_set, n_get = bind(ctypes.CDLL(str(nothing)))
    comp = s.component
    null = ctypes.c_void_p(1)

    def velarium_step(_k):
        assert v_step(comp, clock["t"], h, 1) == 0
        clock["t"] += h

    def velarium_ssg(_k):
        v_set(comp, vr_in, 1, value)
        assert v_step(comp, clock["t"], h, 1) == 0
        clock["t"] += h
        v_get(comp, vr_out, len(outs), got)

    moved = (ctypes.c_double * 1)(start)

    def velarium_moved(k):
        moved[0] = start * (1.001 if k % 2 else 1.0) if start != 0 else (1e-3 if k % 2 else 0.0)
        v_set(comp, vr_in, 1, moved)
        assert v_step(comp, clock["t"], h, 1) == 0
        clock["t"] += h
        v_get(comp, vr_out, len(outs), got)

    def nothing_step(_k):
        n_step(null, 0.0, h, 1)

    def nothing_ssg(_k):
        n_set(null, vr_in, 1, value)
        n_step(null, 0.0, h, 1)
        n_get(null, vr_out, len(outs), got)

    hogs = []
    if loaded:
        for _ in range(os.cpu_count() or 2):
            hogs.append(subprocess.Popen([sys.executable, "-c", "while True: pass"]))
        time.sleep(2.0)
    try:
        results = [
            ("do-nothing step", rounds(nothing_step, 20000)),
            ("velarium step (input unchanged)", rounds(velarium_step, 20000)),
            ("do-nothing set+step+get", rounds(nothing_ssg, 20000)),
            ("velarium set+step+get (unchanged)", rounds(velarium_ssg, 20000)),
        ]
        try:
            results.append(("velarium set+step+get (input moved: a solve)", rounds(velarium_moved, 500)))
        except AssertionError:
            # A step that did not converge (Discard): no figure for this model.
            results.append(("velarium set+step+get (input moved: Discard)", (float("nan"), float("nan"))))
        load = os.getloadavg()
    finally:
        for p in hogs:
            p.kill()
            p.wait()
    # Back to the start value before freeing (nothing else to restore).
    s.terminate()
    s.freeInstance()
    s.freeLibrary()
    shutil.rmtree(work, ignore_errors=True)
    cpu = "unknown"
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            cpu = line.split(":", 1)[1].strip()
            break
    print(f"model {model}; CPU {cpu}; {os.cpu_count()} cores; {'loaded (busy loop per core)' if loaded else 'no load added'}; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    print(f"{'call':48s} {'wall us':>9s} {'cpu us':>9s}")
    for name, (wall, cpu_us) in results:
        print(f"{name:48s} {wall:9.2f} {cpu_us:9.2f}")
    base = dict(results)
    print(f"ratio step / do-nothing step: {base['velarium step (input unchanged)'][0] / base['do-nothing step'][0]:.2f}")
    print(f"ratio set+step+get / do-nothing: {base['velarium set+step+get (unchanged)'][0] / base['do-nothing set+step+get'][0]:.2f}")


if __name__ == "__main__":
    main()
