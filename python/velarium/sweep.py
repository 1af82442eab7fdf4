"""Parameter and load-history sweeps through an FMU on Dask (docs/fmu.md, "Sweeps").

    python -m velarium.sweep SCENE.json|MODEL.fmu [--grid NAME=V1,V2,...|NAME=LO:HI:N]...
        [--sample N --range NAME=LO:HI... --seed S] [--steps K]
        [--scheduler local|synchronous|threads|processes|tcp://HOST:PORT] [--workers W]
        [--partitions P] [--engine fmu|solve] [--out DIR]

Every run is one quasi-static load history through the FMU: each input ramped from its start
value to its ramp target (its `max`, or 10x start, or 1.0; a swept input sets the target) in K
steps over the default experiment (K from its step size unless --steps), extended by one step
so that the last recorded row carries the ramp's last value (the one-step lag, docs/fmu.md). A
swept parameter is set as a start value before initialization. `--grid` values combine as a
full factorial; `--sample N` draws N points uniformly from the `--range` boxes (seeded).

With --engine solve, each run is one `velarium solve` of the same ramp instead (no FMU instance,
inputs only; the workers must see the command at the same path), recorded on the same grid:
the same table, bit for bit. Runs go to Dask in partitions: each partition extracts the FMU once, instantiates it once,
`fmi2Reset`s it between runs, and at the end frees the instance and unloads the library with
`fmpy.freeLibrary` (the pattern of fmpy's examples/parameter_variation.py), so a long-lived
worker does not keep one copy of the library per partition. The default scheduler is a local
cluster of W single-threaded worker processes; `synchronous` runs everything in this process
(debugging, CI), any other value is the address of a running scheduler (its workers need fmpy
and numpy installed; the FMU's bytes and the worker function travel with the tasks).

Output (DIR, default build/sweeps/<Name>/ under the current directory):
    sweep.csv      one tidy table: one line per run and recorded time, columns
                   run, <swept values>, status (ok | discard), time, <inputs carried>, <outputs>;
                   a swept parameter's column is its name, a swept input's `<name>_target`
                   (its `<name>` column is the load each row carries)
    sweep.parquet  the same table, if pyarrow is installed
    sweep.png      every output's last value against the first swept variable (one line per
                   value of the second), runs that ended early (Discard) marked x
and it prints the number of runs, the wall time of the compute and the throughput (runs/s).

Examples:
  python -m velarium.sweep modelDescription/PrestressedCable/scene.json --grid P=2000,4000 --steps 2 --scheduler synchronous --out build/sweeps/PrestressedCable
"""

from __future__ import annotations

import argparse
import csv
import itertools
import math
import os
import sys
import tempfile
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from . import tables as vr
from ._locate import command
from .engine import load_scene, pack


# ----------------------------------------------------------------------------- the plan

def parse_grid(spec: str) -> tuple[str, list[float]]:
    """`NAME=V1,V2,...` or `NAME=LO:HI:N` (N values from LO to HI inclusive)."""
    name, _, values = spec.partition("=")
    if not name or not values:
        raise ValueError(f"--grid {spec!r}: expected NAME=V1,V2,... or NAME=LO:HI:N")
    if ":" in values:
        lo, hi, n = values.split(":")
        return name, [float(v) for v in np.linspace(float(lo), float(hi), int(n))]
    return name, [float(v) for v in values.split(",")]


def parse_range(spec: str) -> tuple[str, float, float]:
    name, _, values = spec.partition("=")
    lo, _, hi = values.partition(":")
    if not name or not lo or not hi:
        raise ValueError(f"--range {spec!r}: expected NAME=LO:HI")
    return name, float(lo), float(hi)


def plan(grid: list[tuple[str, list[float]]], ranges: list[tuple[str, float, float]], samples: int, seed: int) -> tuple[list[str], list[dict]]:
    """The swept names and one dict of values per run."""
    if samples:
        if not ranges:
            raise ValueError("--sample needs at least one --range NAME=LO:HI")
        rng = np.random.default_rng(seed)
        names = [n for n, _, _ in ranges]
        runs = [{n: float(rng.uniform(lo, hi)) for n, lo, hi in ranges} for _ in range(samples)]
        return names, runs
    names = [n for n, _ in grid]
    runs = [dict(zip(names, combo)) for combo in itertools.product(*(v for _, v in grid))]
    return names, runs or [{}]


def spec_of(md, swept: list[str], steps: int | None) -> dict:
    """Everything a worker needs about the FMU, as plain data."""
    variables = {v.name: v for v in md.modelVariables}
    for name in swept:
        v = variables.get(name)
        if v is None or v.causality not in ("input", "parameter"):
            choices = sorted(n for n, v in variables.items() if v.causality in ("input", "parameter"))
            raise ValueError(f"{name!r} is not an input or a parameter of {md.modelName}: {choices}")
    start, stop = vr.experiment(md)
    h0 = float(md.defaultExperiment.stepSize)
    k = steps or max(1, round((stop - start) / h0))
    return {
        "guid": md.guid,
        "model_identifier": md.coSimulation.modelIdentifier,
        "start": start,
        "stop": stop,
        "steps": k,
        "inputs": [(v.name, v.valueReference, float(v.start), vr.ramp_target(v)) for v in vr.inputs(md)],
        "parameters": {v.name: v.valueReference for v in md.modelVariables if v.causality == "parameter"},
        "outputs": [(v.name, v.valueReference, v.type) for v in vr.outputs(md)],
        "swept": swept,
        "columns": {n: (f"{n}_target" if variables[n].causality == "input" else n) for n in swept},
    }


# ----------------------------------------------------------------------------- the worker

def run_partition(runs: list[tuple[int, dict]], fmu_bytes: bytes, spec: dict) -> list[dict]:
    """Run some of the sweep's runs in one FMU instance; returns the tidy rows. Self-contained
    (imports inside) so that Dask can ship it to any worker."""
    import shutil as _shutil
    import tempfile as _tempfile
    from pathlib import Path as _Path

    import fmpy
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    tmp = _Path(_tempfile.mkdtemp(prefix="velarium-sweep-"))
    rows: list[dict] = []
    fmu = None
    try:
        path = tmp / "model.fmu"
        path.write_bytes(fmu_bytes)
        unzipdir = fmpy.extract(str(path), unzipdir=str(tmp / "unzipped"))
        fmu = FMU2Slave(guid=spec["guid"], unzipDirectory=unzipdir, modelIdentifier=spec["model_identifier"], instanceName="sweep")
        fmu.instantiate()
        start, stop, k = spec["start"], spec["stop"], spec["steps"]
        h = (stop - start) / k
        real_out = [(n, r) for n, r, t in spec["outputs"] if t == "Real"]
        int_out = [(n, r) for n, r, t in spec["outputs"] if t != "Real"]
        for index, values in runs:
            fmu.reset()
            # The ramp of every input, k + 1 points, then one more step holding the last value.
            ramps = []
            for name, ref, u0, u1 in spec["inputs"]:
                u1 = values.get(name, u1)
                ramps.append((name, ref, [u0 + (u1 - u0) * j / k for j in range(k + 1)] + [u1]))
            fmu.setupExperiment(startTime=start, stopTime=start + (k + 1) * h)
            for name, value in values.items():
                if name in spec["parameters"]:
                    fmu.setReal([spec["parameters"][name]], [value])
            fmu.enterInitializationMode()
            for _, ref, u in ramps:
                fmu.setReal([ref], [u[0]])
            fmu.exitInitializationMode()

            def record(t: float, j: int, status: str) -> None:
                row = {"run": index, **{spec["columns"][n]: values[n] for n in spec["swept"]}, "status": status, "time": t}
                for name, _, u in ramps:
                    row[name] = u[j]
                if real_out:
                    row.update(zip((n for n, _ in real_out), fmu.getReal([r for _, r in real_out])))
                if int_out:
                    row.update(zip((n for n, _ in int_out), (float(x) for x in fmu.getInteger([r for _, r in int_out]))))
                rows.append(row)

            record(start, 0, "ok")
            status = "ok"
            for j in range(k + 1):
                t = start + j * h
                for _, ref, u in ramps:
                    fmu.setReal([ref], [u[j]])
                try:
                    fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                except FMICallException:
                    # Discard: the FMU kept its last equilibrium; the run ends here.
                    status = "discard"
                    break
                record(start + (j + 1) * h, j, "ok")
            if status != "ok":
                for row in rows:
                    if row["run"] == index:
                        row["status"] = status
    finally:
        if fmu is not None:
            try:
                fmu.fmi2FreeInstance(fmu.component)
            finally:
                # Unload the library now (the worker lives on), as fmpy's parameter_variation.py.
                fmpy.freeLibrary(fmu.dll._handle)
        _shutil.rmtree(tmp, ignore_errors=True)
    return rows


def run_partition_solve(runs: list[tuple[int, dict]], scene_text: str, spec: dict) -> list[dict]:
    """The same runs through the `velarium` command (one `velarium solve` per run; no FMU,
    no lag), recorded on the FMU sweep's grid so that the tidy rows are the same: the row at
    t_0 and the row at t_{j+1} are solve's rows 0 and j (the equilibrium under the loads of t_j).
    A step that does not converge ends the run as a Discard does. Self-contained for Dask."""
    import csv as _csv
    import shutil as _shutil
    import subprocess as _subprocess
    import tempfile as _tempfile
    from pathlib import Path as _Path

    tmp = _Path(_tempfile.mkdtemp(prefix="velarium-sweep-"))
    rows: list[dict] = []
    try:
        scene = tmp / "scene.json"
        scene.write_text(scene_text)
        start, stop, k = spec["start"], spec["stop"], spec["steps"]
        h = (stop - start) / k
        # The FMU path's column order: Real outputs, then Integer ones.
        outputs = [n for n, _, t in spec["outputs"] if t == "Real"] + [n for n, _, t in spec["outputs"] if t != "Real"]
        for index, values in runs:
            ramps = []
            for name, _, u0, u1 in spec["inputs"]:
                u1 = values.get(name, u1)
                ramps.append((name, [u0 + (u1 - u0) * j / k for j in range(k + 1)]))
            loads, result = tmp / "loads.csv", tmp / "result.csv"
            with open(loads, "w") as f:
                f.write(",".join(["time"] + [n for n, _ in ramps]) + "\n")
                for j in range(k + 1):
                    f.write(",".join([repr(start + j * h)] + [repr(u[j]) for _, u in ramps]) + "\n")
            result.unlink(missing_ok=True)
            run = _subprocess.run([spec["command"], "solve", str(scene), "--loads", str(loads), "--out", str(result), "--quiet"],
                                  capture_output=True, text=True)
            if run.returncode == 0:
                status = "ok"
            elif run.returncode == 1 and "did not converge" in run.stderr and result.is_file():
                status = "discard"
            else:
                raise RuntimeError(f"run {index}: velarium solve failed ({run.returncode}):\n{run.stderr}")
            with open(result) as f:
                solved = [{n: float(v) for n, v in r.items()} for r in _csv.DictReader(f)]
            swept = {spec["columns"][n]: values[n] for n in spec["swept"]}
            if solved:
                rows.append({"run": index, **swept, "status": status, "time": start, **{n: u[0] for n, u in ramps},
                             **{n: solved[0][n] for n in outputs}})
            for j, r in enumerate(solved):
                rows.append({"run": index, **swept, "status": status, "time": start + (j + 1) * h,
                             **{n: u[j] for n, u in ramps}, **{n: r[n] for n in outputs}})
    finally:
        _shutil.rmtree(tmp, ignore_errors=True)
    return rows


# ----------------------------------------------------------------------------- Dask

def compute(runs: list[dict], fmu: Path, spec: dict, scheduler: str, workers: int, partitions: int | None,
            show: bool = True, engine: str = "fmu") -> tuple[list[dict], float]:
    """All rows of all runs, in run order, and the wall time of the compute (seconds)."""
    try:
        import dask.bag as db
    except ImportError as e:  # the optional extra: a plain `pip install .` does not bring Dask
        raise ImportError("velarium.sweep runs on Dask, which is not installed: pip install \"velarium[sweep]\" "
                          "(or \".[sweep]\" in a checkout) brings dask and distributed") from e

    try:  # ship the worker function by value: workers need not have the package installed
        import cloudpickle

        if __name__ != "__main__":
            cloudpickle.register_pickle_by_value(sys.modules[__name__])
    except Exception:
        pass
    if engine == "solve":
        worker, payload = run_partition_solve, spec["scene_text"]
    else:
        worker, payload = run_partition, fmu.read_bytes()
    indexed = list(enumerate(runs))
    parts = partitions or max(1, min(len(indexed), 4 * max(1, workers)))
    if scheduler in ("synchronous", "threads", "processes"):
        from dask.diagnostics import ProgressBar

        bag = db.from_sequence(indexed, npartitions=parts).map_partitions(worker, payload, spec)
        t0 = time.perf_counter()
        if show:
            with ProgressBar(dt=0.5):
                rows = bag.compute(scheduler=scheduler, num_workers=workers)
        else:
            rows = bag.compute(scheduler=scheduler, num_workers=workers)
        elapsed = time.perf_counter() - t0
    else:
        from dask.distributed import Client, LocalCluster, progress

        cluster = None
        if scheduler == "local":
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
            client = Client(cluster)
        else:
            client = Client(scheduler)
        try:
            client.wait_for_workers(workers if cluster is not None else 1, timeout=120)
            t0 = time.perf_counter()
            # The FMU's bytes go to every worker once (broadcast): a task that needed them from
            # one worker would pull every partition onto that worker (data locality).
            fmu_future = client.scatter(payload, broadcast=True, hash=False)
            bounds = np.linspace(0, len(indexed), parts + 1).round().astype(int)
            chunks = [indexed[a:b] for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
            futures = [client.submit(worker, chunk, fmu_future, spec, pure=False) for chunk in chunks]
            if show:
                progress(futures)
                print(file=sys.stderr)
            rows = [row for part in client.gather(futures) for row in part]
            elapsed = time.perf_counter() - t0
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    rows.sort(key=lambda r: (r["run"], r["time"]))
    return rows, elapsed


# ----------------------------------------------------------------------------- output

def write_table(rows: list[dict], out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    columns = list(rows[0].keys())
    for r in rows:
        columns += [c for c in r if c not in columns]
    path = out / "sweep.csv"
    tmp = path.with_suffix(".csv.partial")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        for r in rows:
            w.writerow({c: (repr(v) if isinstance(v, float) else v) for c, v in r.items()})
    tmp.replace(path)
    written = [path]
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return written
    pq.write_table(pa.Table.from_pylist(rows), out / "sweep.parquet")
    written.append(out / "sweep.parquet")
    return written


def last_rows(rows: list[dict]) -> list[dict]:
    last: dict[int, dict] = {}
    for r in rows:
        last[r["run"]] = r
    return [last[k] for k in sorted(last)]


def summary_plot(rows: list[dict], spec: dict, path: Path, title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    finals = last_rows(rows)
    swept = spec["swept"]
    outputs = [n for n, _, _ in spec["outputs"]][:8]
    columns = min(4, len(outputs))
    lines = -(-len(outputs) // columns)
    fig, axes = plt.subplots(lines, columns, figsize=(4.2 * columns, 3.5 * lines), squeeze=False)
    for ax in axes.flat[len(outputs):]:
        ax.set_visible(False)
    columns_of = [spec["columns"][n] for n in swept]
    x_name = columns_of[0] if swept else "run"
    groups: dict = {}
    for r in finals:
        groups.setdefault(r[columns_of[1]] if len(swept) > 1 else None, []).append(r)
    for ax, name in zip(axes.flat, outputs):
        for key, group in groups.items():
            group = sorted(group, key=lambda r: r[x_name])
            x = [r[x_name] for r in group]
            y = [r[name] for r in group]
            label = None if key is None else f"{columns_of[1]} = {key:.4g}"
            line, = ax.plot(x, y, "o-" if not len(swept) > 2 else "o", ms=3, label=label)
            bad = [(a, b) for a, b, r in zip(x, y, group) if r["status"] != "ok"]
            if bad:
                ax.plot(*zip(*bad), "x", color=line.get_color(), ms=8)
        ax.set_xlabel(x_name)
        ax.set_ylabel(f"{name} (last row)")
        ax.grid(True, alpha=0.3)
    if len(groups) > 1 and len(groups) <= 8:
        axes.flat[0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


@dataclass
class SweepResult:
    """What :func:`sweep` returns: the tidy rows (one dict per run and recorded time: ``run``, the
    swept values, ``status`` ``ok``/``discard``, ``time``, the loads carried, the outputs), the
    number of runs, the wall time of the compute and the throughput, and the files written."""

    runs: int
    seconds: float
    runs_per_second: float
    rows: list[dict]
    files: list[Path] = field(default_factory=list)

    def last(self) -> list[dict]:
        """The last recorded row of every run, in run order."""
        return last_rows(self.rows)

    def to_array(self) -> np.ndarray:
        """The rows as a structured array (``status`` a string field, every other one float64)."""
        columns = list(self.rows[0].keys()) if self.rows else []
        for r in self.rows:
            columns += [c for c in r if c not in columns]
        dtype = [(c, "U8" if c == "status" else np.float64) for c in columns]
        out = np.zeros(len(self.rows), dtype=dtype)
        for i, r in enumerate(self.rows):
            for c in columns:
                out[c][i] = r.get(c, "" if c == "status" else np.nan)
        return out


def sweep(
    target: str | os.PathLike | Mapping[str, Any],
    grid: Mapping[str, Sequence[float]] | None = None,
    *,
    sample: int = 0,
    ranges: Mapping[str, tuple[float, float]] | None = None,
    seed: int = 1,
    steps: int | None = None,
    scheduler: str = "local",
    workers: int = 2,
    partitions: int | None = None,
    out: str | os.PathLike | None = None,
    plot: bool = True,
    progress: bool = True,
    engine: str = "fmu",
) -> SweepResult:
    """Sweep parameters and input ramp targets of a scene or FMU on Dask.

    ``grid`` maps a parameter or input name to its values (full factorial); or ``sample=N`` draws
    N points uniformly from ``ranges`` (name -> (low, high)), seeded by ``seed``. Every run ramps
    each input from its start value to its ramp target (a swept input sets it) in ``steps``
    steps over the default experiment (default: from its step size), extended by one step so
    the last recorded row carries the last load. ``scheduler``: ``local`` (a cluster of
    ``workers`` single-threaded processes), ``synchronous``, ``threads``, ``processes`` or a
    scheduler address. With ``out``, writes ``sweep.csv`` (and ``sweep.parquet`` with pyarrow,
    ``sweep.png`` with ``plot``) there. A scene is packed into a temporary FMU first.

    ``engine="fmu"`` (default) runs each partition in one FMU instance through fmpy;
    ``engine="solve"`` runs each run through the bundled `velarium solve` instead (no FMU
    instance; inputs only, a swept parameter is an error; the workers must see the command at
    the same path, so a local cluster or this machine): the same tidy rows, bit for bit.
    """
    import fmpy

    if int(workers) != workers or workers < 1:
        raise ValueError(f"workers: {workers!r} is not a positive whole number")
    if partitions is not None and (int(partitions) != partitions or partitions < 1):
        raise ValueError(f"partitions: {partitions!r} is not a positive whole number")
    if steps is not None and (int(steps) != steps or steps < 1):
        raise ValueError(f"steps: {steps!r} is not a positive whole number")
    if engine not in ("fmu", "solve"):
        raise ValueError(f"engine: {engine!r} is not 'fmu' or 'solve'")
    if int(sample) != sample or sample < 0:
        raise ValueError(f"sample: {sample!r} is not a whole number >= 0")
    grid_list = []
    for name, values in (grid or {}).items():
        values = [float(v) for v in np.atleast_1d(values)]
        if not values:
            raise ValueError(f"grid.{name}: no values")
        grid_list.append((name, values))
    range_list = []
    for name, bounds in (ranges or {}).items():
        if len(bounds) != 2 or not float(bounds[0]) <= float(bounds[1]):
            raise ValueError(f"ranges.{name}: {bounds!r} is not a (low, high) pair with low <= high")
        range_list.append((name, float(bounds[0]), float(bounds[1])))
    with tempfile.TemporaryDirectory(prefix="velarium-sweep-") as tmp:
        if isinstance(target, Mapping) or Path(target).suffix != ".fmu":
            fmu = pack(target, tmp, fmi=2)[0]
        else:
            fmu = Path(target)
            if not fmu.is_file():
                raise ValueError(f"target: {fmu}: no such file")
        md = fmpy.read_model_description(str(fmu))
        names, runs = plan(grid_list, range_list, sample, seed)
        spec = spec_of(md, names, steps)
        if engine == "solve":
            for name in names:
                if name in spec["parameters"]:
                    raise ValueError(f"{'ranges' if sample else 'grid'}.{name}: engine='solve' sweeps inputs only and "
                                     f"{name} is a parameter: use engine='fmu'")
            with zipfile.ZipFile(fmu) as z:
                spec["scene_text"] = z.read("resources/scene.json").decode()
            spec["command"] = str(command())
        if progress:
            print(f"{md.modelName}: {len(runs)} runs of {spec['steps'] + 1} steps, sweeping {names or 'nothing'}, "
                  f"scheduler {scheduler}" + (f" ({workers} workers)" if scheduler == "local" else ""))
        rows, elapsed = compute(runs, fmu, spec, scheduler, workers, partitions, progress, engine)
    files: list[Path] = []
    if out is not None:
        out = Path(out)
        files = write_table(rows, out)
        if plot:
            files.append(summary_plot(rows, spec, out / "sweep.png", f"{md.modelName}: {len(runs)} runs, last recorded row"))
    rate = len(runs) / elapsed if elapsed > 0 else math.inf
    return SweepResult(runs=len(runs), seconds=elapsed, runs_per_second=rate, rows=rows, files=files)


def main(argv: list[str] | None = None) -> dict:
    """The command line (``python -m velarium.sweep``); returns runs, seconds, runs_per_second,
    rows and out as a dict."""
    parser = argparse.ArgumentParser(prog="python -m velarium.sweep", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("target", type=Path, help="a scene (.json, packed first) or an FMU (.fmu)")
    parser.add_argument("--grid", action="append", default=[], help="NAME=V1,V2,... or NAME=LO:HI:N (repeatable; full factorial)")
    parser.add_argument("--sample", type=int, default=0, help="draw N runs uniformly from the --range boxes instead of a grid")
    parser.add_argument("--range", action="append", default=[], help="NAME=LO:HI for --sample (repeatable)")
    parser.add_argument("--seed", type=int, default=1, help="seed of --sample (default: %(default)s)")
    parser.add_argument("--steps", type=int, default=None, help="load steps per run (default: from the experiment's step size)")
    parser.add_argument("--scheduler", default="local", help="local (default), synchronous, threads, processes, or a scheduler address")
    parser.add_argument("--workers", type=int, default=2, help="workers of the local cluster (default: %(default)s)")
    parser.add_argument("--partitions", type=int, default=None, help="Dask partitions (default: 4 per worker, at most one per run)")
    parser.add_argument("--out", type=Path, default=None, help="output directory (default: build/sweeps/<Name>)")
    parser.add_argument("--engine", choices=["fmu", "solve"], default="fmu",
                        help="fmu: one FMU instance per partition through fmpy (default); solve: `velarium solve` per run")
    args = parser.parse_args(argv)

    import fmpy

    try:
        grid = dict(parse_grid(g) for g in args.grid)
        ranges = {n: (lo, hi) for n, lo, hi in (parse_range(r) for r in args.range)}
        if args.target.suffix == ".fmu":
            name = fmpy.read_model_description(str(args.target)).modelName
        else:
            name = load_scene(args.target).name
        out = args.out or Path("build") / "sweeps" / name
        result = sweep(args.target, grid, sample=args.sample, ranges=ranges, seed=args.seed, steps=args.steps,
                       scheduler=args.scheduler, workers=args.workers, partitions=args.partitions, out=out,
                       engine=args.engine)
    except (ValueError, RuntimeError, FileNotFoundError) as e:
        sys.exit(f"velarium.sweep: {e}")
    discards = sum(r["status"] != "ok" for r in result.last())
    print(f"{result.runs} runs ({discards} ended early with Discard) in {result.seconds:.2f} s: "
          f"{result.runs_per_second:.2f} runs/s")
    for p in result.files:
        print(f"wrote {p}")
    return {"runs": result.runs, "seconds": result.seconds, "runs_per_second": result.runs_per_second,
            "rows": result.rows, "out": out}


if __name__ == "__main__":
    main()
