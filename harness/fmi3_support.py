"""Helpers of the FMI 3.0 tests (``test_fmi3.py``): the 75 function names of ``fmi3Functions.h``,
a recording FMI 3 logger, and fmpy's low-level ``FMU3Slave`` with explicit cleanup.

The FMI 3 logger is not variadic (``fmi3LogMessageCallback(env, status, category, message)``)
and fmpy keeps the callback on the slave object, so no process-wide proxy is involved (unlike
FMI 2, see ``fmi_support``).
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import fmpy
from fmpy.fmi3 import FMU3Slave

import velarium_run as vr

# Every function of fmi3Functions.h (FMI 3.0): an FMU exports all 75 (the FMI 3.0 standard, fmi3Functions.h).
FMI3_FUNCTIONS = sorted(
    """fmi3GetVersion fmi3SetDebugLogging fmi3InstantiateModelExchange fmi3InstantiateCoSimulation
    fmi3InstantiateScheduledExecution fmi3FreeInstance fmi3EnterInitializationMode
    fmi3ExitInitializationMode fmi3EnterEventMode fmi3Terminate fmi3Reset
    fmi3GetFloat32 fmi3GetFloat64 fmi3GetInt8 fmi3GetUInt8 fmi3GetInt16 fmi3GetUInt16 fmi3GetInt32
    fmi3GetUInt32 fmi3GetInt64 fmi3GetUInt64 fmi3GetBoolean fmi3GetString fmi3GetBinary fmi3GetClock
    fmi3SetFloat32 fmi3SetFloat64 fmi3SetInt8 fmi3SetUInt8 fmi3SetInt16 fmi3SetUInt16 fmi3SetInt32
    fmi3SetUInt32 fmi3SetInt64 fmi3SetUInt64 fmi3SetBoolean fmi3SetString fmi3SetBinary fmi3SetClock
    fmi3GetNumberOfVariableDependencies fmi3GetVariableDependencies
    fmi3GetFMUState fmi3SetFMUState fmi3FreeFMUState fmi3SerializedFMUStateSize
    fmi3SerializeFMUState fmi3DeserializeFMUState
    fmi3GetDirectionalDerivative fmi3GetAdjointDerivative
    fmi3EnterConfigurationMode fmi3ExitConfigurationMode
    fmi3GetIntervalDecimal fmi3GetIntervalFraction fmi3GetShiftDecimal fmi3GetShiftFraction
    fmi3SetIntervalDecimal fmi3SetIntervalFraction fmi3SetShiftDecimal fmi3SetShiftFraction
    fmi3EvaluateDiscreteStates fmi3UpdateDiscreteStates
    fmi3EnterContinuousTimeMode fmi3CompletedIntegratorStep fmi3SetTime fmi3SetContinuousStates
    fmi3GetContinuousStateDerivatives fmi3GetEventIndicators fmi3GetContinuousStates
    fmi3GetNominalsOfContinuousStates fmi3GetNumberOfEventIndicators fmi3GetNumberOfContinuousStates
    fmi3EnterStepMode fmi3GetOutputDerivatives fmi3DoStep fmi3ActivateModelPartition""".split()
)
assert len(FMI3_FUNCTIONS) == 75

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3

# (status, category, message) of every FMI 3 message since the last clear().
RECORDS: list[tuple[int, str, str]] = []


def record(_env, status, category, message) -> None:
    RECORDS.append((status, (category or b"").decode("utf-8"), (message or b"").decode("utf-8")))


def clear_log() -> None:
    RECORDS.clear()


def messages(status: int | None = None) -> list[str]:
    return [m for s, _, m in RECORDS if status is None or s == status]


def fmi3_path(fmi2_fmu: Path) -> Path:
    """The FMI 3 archive `velarium pack` writes beside ``<Name>.fmu``."""
    return fmi2_fmu.with_name(f"{fmi2_fmu.stem}_fmi3.fmu")


@contextlib.contextmanager
def slave(unzipdir: Path, md, name: str = "instance", instantiate: bool = True, logging_on: bool = False, **kwargs):
    """An FMU3Slave with the recording logger; always freed (instance and library)."""
    s = FMU3Slave(guid=md.guid, unzipDirectory=str(unzipdir), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=name)
    s.component = None
    try:
        if instantiate:
            s.instantiate(loggingOn=logging_on, logMessage=record, **kwargs)
        yield s
    finally:
        if s.component:
            s.fmi3FreeInstance(s.component)
            s.component = None
        s.freeLibrary()


def initialize(s, md, values: dict | None = None) -> None:
    start, stop = vr.experiment(md)
    s.enterInitializationMode(startTime=start, stopTime=stop)
    for name, value in (values or {}).items():
        s.setFloat64([vref(md, name)], [value])
    s.exitInitializationMode()


def vref(md, name: str) -> int:
    return next(v.valueReference for v in md.modelVariables if v.name == name)


def outputs(md, types=("Float64",)) -> list:
    return [v for v in vr.outputs(md) if v.type in types]


def read_outputs(s, md) -> list[float]:
    """Every Float64 output, then every Int32 output (as floats)."""
    reals = [v.valueReference for v in outputs(md)]
    ints = [v.valueReference for v in outputs(md, ("Int32",))]
    return list(s.getFloat64(reals)) + [float(i) for i in s.getInt32(ints)]


def set_inputs(s, md, row) -> None:
    ins = vr.inputs(md)
    if ins:
        s.setFloat64([v.valueReference for v in ins], [float(row[v.name]) for v in ins])


def skip_arrays(md, covered: str = "harness/test_arrays.py, tests/fmi/importer.rs and tests/fmi/arrays.rs") -> None:
    """Skip a test that drives scalar variables only on an FMU with array variables, naming
    where its arrays are tested instead."""
    import pytest

    arrays = [v.name for v in md.modelVariables if getattr(v, "dimensions", None)]
    if arrays:
        pytest.skip(f"array variables {arrays}: this test drives scalars; the arrays are tested in {covered}")


def skip_array_model(model: str) -> None:
    """skip_arrays for a shipped scene by name (its packed FMI 3 archive)."""
    import fmpy

    import velarium_run as vr

    path = vr.FMU_DIR / f"{model}_fmi3.fmu"
    if path.is_file():
        skip_arrays(fmpy.read_model_description(str(path)))
