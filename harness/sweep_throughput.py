"""Benchmark: a sweep's throughput (runs/s) through the package's two engines, and the share of
a run an in-process binding (PyO3) could save. Prints numbers; asserts nothing about speed.

    .venv/bin/python harness/sweep_throughput.py [--model WrinkledShear] [--input shear] [--runs 48] [--steps 21]

Three ways, the same runs (one input's ramp target swept over --runs values, target/runs to
target; the other inputs ramp to their own targets), 8 Dask partitions:

1. `velarium.sweep.sweep(engine="fmu")`: the FMU through fmpy (ctypes, the engine in the
   worker's process; one instance per partition, fmi2Reset between runs), on Dask's
   synchronous scheduler, then on a 2-worker local cluster;
2. `velarium.sweep.sweep(engine="solve")`: the bundled `velarium solve`, one process per run,
   the same two schedulers (the same tidy rows, bit for bit: harness/test_python_package.py);
3. the ceiling of any in-process binding: the same FMU loop by hand, timing only the calls that
   do the engine's work (instantiate, reset, initialization, DoStep). A PyO3 module would still
   do that work; everything else (setReal/getReal through ctypes, the Python loop) is the most
   it could save.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import fmpy
import numpy as np
from fmpy.fmi2 import FMU2Slave

import velarium_run as vr
from velarium.sweep import sweep


def targets(md, runs: int, name: str | None) -> tuple[str, np.ndarray]:
    ins = {v.name: v for v in vr.inputs(md)}
    if name is not None and name not in ins:
        raise SystemExit(f"--input {name}: {md.modelName} has no such input ({sorted(ins)})")
    v = ins[name] if name else vr.inputs(md)[0]
    top = vr.ramp_target(v)
    return v.name, np.linspace(top / runs, top, runs)


def engine_share(fmu: Path, md, name: str, values: np.ndarray, steps: int) -> tuple[float, float]:
    """(wall time of the hand loop, time inside the engine's calls) over all runs."""
    tmp = Path(tempfile.mkdtemp(prefix="velarium-bench-"))
    unzipdir = fmpy.extract(str(fmu), str(tmp / "u"))
    ins = {v.name: v for v in vr.inputs(md)}
    refs = [v.valueReference for v in vr.outputs(md) if v.type == "Real"]
    start, stop = vr.experiment(md)
    h = (stop - start) / steps
    inside = 0.0
    t0 = time.perf_counter()
    tic = time.perf_counter()
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="b")
    s.instantiate()
    inside += time.perf_counter() - tic
    try:
        for u1 in values:
            ramp = {n: np.linspace(float(v.start), u1 if n == name else vr.ramp_target(v), steps + 1) for n, v in ins.items()}
            tic = time.perf_counter()
            s.reset()
            s.setupExperiment(startTime=start)
            s.enterInitializationMode()
            s.exitInitializationMode()
            inside += time.perf_counter() - tic
            s.getReal(refs)
            for j in range(steps + 1):
                s.setReal([ins[n].valueReference for n in ins], [float(ramp[n][min(j, steps)]) for n in ins])
                tic = time.perf_counter()
                s.doStep(start + j * h, h)
                inside += time.perf_counter() - tic
                s.getReal(refs)
    finally:
        s.terminate()
        s.freeInstance()
    return time.perf_counter() - t0, inside


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="WrinkledShear")
    parser.add_argument("--runs", type=int, default=48)
    parser.add_argument("--steps", type=int, default=21)
    parser.add_argument("--input", default=None, help="the input whose ramp target is swept (default: the first)")
    args = parser.parse_args()
    fmu = vr.FMU_DIR / f"{args.model}.fmu"
    md = fmpy.read_model_description(str(fmu))
    name, values = targets(md, args.runs, args.input)
    n = len(values)
    print(f"{args.model}: {n} runs of {args.steps + 1} steps (+1 for the lag), {name} target "
          f"{values[0]:.4g}..{values[-1]:.4g}; load average before: {os.getloadavg()[0]:.2f}")
    grid = {name: list(values)}
    for engine in ("fmu", "solve"):
        for label, kwargs in (("synchronous (1 process)", {"scheduler": "synchronous"}),
                              ("local cluster, 2 workers", {"scheduler": "local", "workers": 2})):
            r = sweep(fmu, grid, steps=args.steps, progress=False, partitions=8, engine=engine, **kwargs)
            print(f"  {f'engine={engine}, {label}':44s} {r.runs_per_second:8.2f} runs/s  ({r.seconds:.2f} s)")
    wall, inside = engine_share(fmu, md, name, values, args.steps)
    print(f"  {'FMU loop by hand, 1 process':44s} {n / wall:8.2f} runs/s  ({wall:.2f} s)")
    print(f"  {'  of which inside the engine':44s} {n / inside:8.2f} runs/s  ({inside:.2f} s, {100 * inside / wall:.1f} %): "
          f"the ceiling of an in-process binding")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
