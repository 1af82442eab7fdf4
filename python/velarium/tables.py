"""Load tables and result tables: NumPy structured arrays of float64.

A load table has the field ``time`` first, then one field per input it sets (any subset of the
scene's inputs): exactly what ``fmpy.simulate_fmu(input=...)`` takes and what ``velarium
solve --loads`` reads as CSV. Results come back in the same form (``time`` and one field per
output); :func:`to_pandas` turns either into a DataFrame.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Union

import numpy as np

if TYPE_CHECKING:
    import pandas

#: What the functions taking a load table accept: a structured array, a mapping of column name to
#: values (``{"time": [...], "F": [...]}``), a pandas DataFrame, or the path of a CSV file.
LoadsLike = Union[np.ndarray, Mapping[str, Any], "pandas.DataFrame", str, os.PathLike]


def as_table(loads: LoadsLike, what: str = "loads") -> np.ndarray:
    """The load table as a float64 structured array with ``time`` first; a bad table is a
    ``ValueError`` naming the column (and row) at fault."""
    if isinstance(loads, (str, os.PathLike)):
        path = Path(loads)
        if not path.is_file():
            raise ValueError(f"{what}: {path}: no such file")
        return as_table(read_csv(path), what=f"{what} ({path})")
    if isinstance(loads, np.ndarray):
        if loads.dtype.names is None:
            raise ValueError(f"{what}: a plain array has no column names: pass a structured array, a dict of columns "
                             "or a DataFrame with a 'time' column and one column per input")
        columns = {n: loads[n] for n in loads.dtype.names}
    elif hasattr(loads, "to_dict") and hasattr(loads, "columns"):  # a pandas DataFrame
        columns = {str(n): np.asarray(loads[n]) for n in loads.columns}
    elif isinstance(loads, Mapping):
        columns = {str(n): v for n, v in loads.items()}
    else:
        raise ValueError(f"{what}: expected a structured array, a dict of columns, a DataFrame or a CSV path, "
                         f"got {type(loads).__name__}")
    if "time" not in columns:
        raise ValueError(f"{what}: no 'time' column (columns: {sorted(columns)})")
    arrays = {}
    length = None
    for name, values in columns.items():
        try:
            a = np.asarray(values, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{what}.{name}: not numbers ({e})") from None
        if length is not None and len(a) != length:
            raise ValueError(f"{what}.{name}: {len(a)} rows, but 'time' has {length}")
        length = len(a) if length is None else length
        bad = np.flatnonzero(~np.isfinite(a))
        if len(bad):
            raise ValueError(f"{what}.{name}, row {int(bad[0])}: {a[bad[0]]} is not a finite number")
        arrays[name] = a
    if not length:
        raise ValueError(f"{what}: the table has no rows")
    t = arrays["time"]
    back = np.flatnonzero(np.diff(t) <= 0)
    if len(back):
        k = int(back[0]) + 1
        raise ValueError(f"{what}.time, row {k}: {t[k]} does not come after row {k - 1}'s {t[k - 1]} (times must increase)")
    names = ["time"] + [n for n in arrays if n != "time"]
    table = np.zeros(length, dtype=[(n, np.float64) for n in names])
    for n in names:
        table[n] = arrays[n]
    return table


def ramp_table(model_description, steps: int) -> np.ndarray:
    """Every input of an FMU ramped linearly from its start value to :func:`ramp_target` over the
    default experiment, on the grid fmpy uses (``t_k = start + k * h``): ``steps + 1`` rows."""
    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps: {steps!r} is not a positive whole number")
    start, stop = experiment(model_description)
    h = (stop - start) / steps
    ins = inputs(model_description)
    table = np.zeros(steps + 1, dtype=[("time", np.float64)] + [(v.name, np.float64) for v in ins])
    for k in range(steps + 1):
        table["time"][k] = start + k * h
    for v in ins:
        u0, u1 = float(v.start), ramp_target(v)
        table[v.name] = [u0 + (u1 - u0) * k / steps for k in range(steps + 1)]
    return table


def extend_by_one_step(table: np.ndarray) -> np.ndarray:
    """The table with one more row, one step after the last, holding the last row's loads.

    The one-step lag of co-simulation (docs/fmu.md, "Stepping"): fmpy sets u(t_k) before
    DoStep(t_k, h) and records the outputs at t_{k+1}, so the row recorded at t_{k+1} is the
    equilibrium under u(t_k) and the last row of a table is never carried by any recorded row.
    Run the extended table (stop time one step later) and the last recorded row is the
    equilibrium under the last load of the original table. The step is the table's last one.
    """
    if len(table) < 2:
        raise ValueError("loads: a load table needs at least two rows to know its step")
    h = float(table["time"][-1] - table["time"][-2])
    extra = table[-1:].copy()
    extra["time"][0] = float(table["time"][-1]) + h
    return np.concatenate([table, extra])


def carried_loads(table: np.ndarray, name: str) -> np.ndarray:
    """The load under which each row fmpy records is in equilibrium: u(t_0) at t_0, then u(t_k)
    at t_{k+1} (the one-step lag)."""
    u = table[name]
    return np.concatenate([u[:1], u[:-1]])


def write_loads_csv(table: np.ndarray, path: Path) -> None:
    """The table as `velarium solve` reads it; repr() of a float round-trips exactly."""
    names = table.dtype.names
    with open(path, "w") as f:
        # A 2-D array element's name has a comma ("corners[1,3]"): quoted, as `solve` reads it.
        f.write(",".join(f'"{n}"' if "," in n else n for n in names) + "\n")
        for row in table:
            f.write(",".join(repr(float(row[n])) for n in names) + "\n")


def read_csv(path: Path) -> np.ndarray:
    """A CSV with a header line as a structured float array (``#`` lines skipped)."""
    with open(path) as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    if not rows:
        raise ValueError(f"{path}: empty (no header line)")
    header, data = rows[0], rows[1:]
    out = np.zeros(len(data), dtype=[(n, np.float64) for n in header])
    for i, row in enumerate(data):
        if len(row) != len(header):
            raise ValueError(f"{path}, line {i + 2}: {len(row)} cells, the header has {len(header)}")
        for n, cell in zip(header, row):
            try:
                out[n][i] = float(cell)
            except ValueError:
                raise ValueError(f"{path}, line {i + 2}, column {n}: {cell!r} is not a number") from None
    return out


def to_pandas(table: np.ndarray):
    """A structured array (a load table or a result) as a pandas DataFrame (needs pandas)."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError("velarium.to_pandas needs pandas: pip install pandas (or velarium[pandas])") from None
    return pd.DataFrame.from_records(table)


# ----------------------------------------------------------------------------- FMU variables

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


def is_uniform(t: np.ndarray) -> bool:
    if len(t) < 3:
        return True
    h = np.diff(t)
    return bool(np.all(np.abs(h - h[0]) <= 1e-9 * max(abs(h[0]), math.ulp(1.0))))
