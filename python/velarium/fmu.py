"""Running a Velarium FMU with fmpy: a load table in, the equilibria out, the one-step lag
handled (docs/fmu.md, "Stepping").

fmpy's logger. fmpy formats an FMU's variadic log message in a small native proxy
(``fmpy.logging.addLoggerProxy``) that forwards it to ONE process-wide pointer: the Python
callback of the last callback structure registered. ``fmpy.simulate_fmu(..., logger=f)``
registers a ctypes thunk of ``f`` that lives only as long as that call; afterwards the proxy's
pointer dangles, and the next FMU instance that logs through fmpy's default callbacks jumps into
freed memory: SIGSEGV (docs/fmu.md, "fmpy's logger"). This module therefore keeps one resident
callback registered for the life of the process and puts it back after every run that passed
its own logger: pass ``logger=`` only through :func:`simulate_fmu` / :func:`simulate` /
:func:`run_fmu`, never to ``fmpy.simulate_fmu`` directly.
"""

from __future__ import annotations

import os
from ctypes import byref
from pathlib import Path
from typing import Any, Mapping

import fmpy
import numpy as np
from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, printLogMessage
from fmpy.logging import addLoggerProxy

from .tables import LoadsLike, as_table, extend_by_one_step, is_uniform

#: Wall-clock limit of one simulate_fmu run in seconds: the guard against a master loop that
#: does not advance.
TIMEOUT = 300

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
    """Make ``thunk`` (an ``fmi2CallbackLoggerTYPE`` kept alive by the caller, e.g. a module
    global) the callback every proxied log message reaches, from now on and after every run."""
    _RESIDENT[0] = thunk
    register_resident_logger()


def simulate_fmu(fmu, logger=None, **kwargs):
    """``fmpy.simulate_fmu``; with ``logger``, the resident callback is registered again
    afterwards (also when the run raises), so no later instance reaches the run's freed thunk."""
    if logger is None:
        return fmpy.simulate_fmu(str(fmu), **kwargs)
    try:
        return fmpy.simulate_fmu(str(fmu), logger=logger, **kwargs)
    finally:
        register_resident_logger()


class RunEndedEarly(RuntimeError):
    """A run stopped before its stop time: a step did not converge (fmi2Discard, Terminated),
    or the run timed out. ``rows`` holds what was recorded before it."""

    def __init__(self, message: str, rows: np.ndarray):
        super().__init__(message)
        self.rows = rows


def simulate(fmu: str | os.PathLike, table: np.ndarray | None = None, **kwargs) -> np.ndarray:
    """``simulate_fmu`` with the table's grid as communication grid and a timeout, raw rows as
    fmpy records them (row at t_{k+1} = the equilibrium under the loads of t_k). Raises
    :class:`RunEndedEarly` if the run did not reach its stop time: fmpy ends a run whose step
    returns Discard early without raising."""
    fmu = Path(fmu)
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
        raise RunEndedEarly(
            f"{fmu.name}: the run ended at t = {end}, before stop_time = {stop}: a step did not "
            f"converge (fmi2Discard, Terminated) or timed out; the FMU's log above says which",
            result,
        )
    return result


def run_fmu(fmu: str | os.PathLike, loads: LoadsLike, *, start_values: Mapping[str, Any] | None = None,
            logger=None, timeout: float = TIMEOUT) -> np.ndarray:
    """Run a load table through an FMI 2.0 FMU with fmpy, aligned like :func:`velarium.solve`.

    ``loads`` is a load table (``time`` and inputs) on a uniform time grid. The table is extended
    by one step (:func:`velarium.extend_by_one_step`) and run; the rows fmpy records one step
    late are shifted back, so row k of the result (``time`` = the table's t_k, and every
    output) is the equilibrium under row k's loads, the same numbers as ``velarium.solve``.
    ``start_values`` sets parameters (or input start values) before initialization.
    A step that does not converge raises :class:`RunEndedEarly` with the aligned rows before it.
    """
    fmu = Path(fmu)
    if not fmu.is_file():
        raise ValueError(f"fmu: {fmu}: no such file")
    table = as_table(loads)
    if len(table) < 2:
        raise ValueError("loads: a load table needs at least two rows (the step is their distance)")
    if not is_uniform(table["time"]):
        raise ValueError("loads.time: fmpy steps on a uniform grid; the table's time steps differ "
                         f"({np.unique(np.diff(table['time']))[:4]}...): resample it, or use velarium.solve")
    md = fmpy.read_model_description(str(fmu))
    names = {v.name: v.causality for v in md.modelVariables}
    for name in table.dtype.names[1:]:
        if names.get(name) != "input":
            inputs = sorted(n for n, c in names.items() if c == "input")
            raise ValueError(f"loads.{name}: {md.modelName} has no input {name!r} (inputs: {inputs})")
    for name in start_values or {}:
        if names.get(name) not in ("parameter", "input"):
            settable = sorted(n for n, c in names.items() if c in ("parameter", "input"))
            raise ValueError(f"start_values.{name}: {md.modelName} has no parameter or input {name!r} ({settable})")
    extended = extend_by_one_step(table)
    kwargs: dict = {"timeout": timeout}
    if start_values:
        kwargs["start_values"] = dict(start_values)
    try:
        raw = simulate(fmu, extended, logger=logger, **kwargs)
    except RunEndedEarly as e:
        raise RunEndedEarly(str(e), _align(e.rows, table)) from None
    return _align(raw, table)


def _align(raw: np.ndarray, table: np.ndarray) -> np.ndarray:
    # A run that ends with Discard records the kept state once more at the same time: drop it.
    keep = np.concatenate([[True], np.diff(raw["time"]) > 0])
    rows = raw[keep][1:].copy()
    rows["time"] = table["time"][: len(rows)]
    return rows
