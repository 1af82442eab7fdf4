"""The reported crash: after ``fmpy.simulate_fmu(..., logger=<python callback>)`` a later Dask
sweep (harness/sweep.py, synchronous scheduler) of another Velarium FMU in the same process
died with SIGSEGV inside fmi2DoStep.

Cause (fmpy 0.3.32, not Velarium; docs/fmu.md, "fmpy's logger"): fmpy formats variadic log
messages in a native proxy (``fmpy.logging.addLoggerProxy``) that forwards every message to ONE
process-wide pointer, the Python callback of the last callback structure registered.
``simulate_fmu(logger=f)`` registers a ctypes thunk of ``f`` that is freed when the call returns;
the sweep's instance uses fmpy's default callbacks, whose logger is that proxy, so the first
message the FMU logs (here the Discard of a step that does not converge, always logged) jumps
into freed memory. gdb: ``#0 ?? / #1 logMessage () from fmpy/logging/linux64/logging.so / #2
velarium::fmi::logging::Logger::log_formatted``. Velarium calls exactly the logger pointer it was
given for that instance and keeps none after fmi2FreeInstance (src/fmi/logging.rs).

Each sequence runs in a fresh interpreter (a crash is a negative return code):
- through fmpy alone it is killed by a signal (the crash reproduced, without our harness code
  in the sweep's path other than sweep.py itself);
- through ``velarium_run.simulate_fmu`` (the harness's only way to pass ``logger=``, which
  points the proxy back at a resident callback afterwards) the same sequence exits 0, the
  sweep records its discarded run, and the logger of the first run got that run's Discard
  message.
"""

from __future__ import annotations

import textwrap

import pytest

import fmi_support as fs
import velarium_run as vr

SEQUENCE = textwrap.dedent("""
    import gc, sys, tempfile
    from pathlib import Path
    import fmpy
    import sweep
    import velarium_run as vr

    first, second, out = sys.argv[1], sys.argv[2], sys.argv[3]
    messages = []
    def logger(_env, _name, status, _category, message):
        messages.append(message.decode(errors="replace"))
    kwargs = dict(stop_time=1.0, output_interval=0.25)
    if sys.argv[4] == "fmpy":
        fmpy.simulate_fmu(first, logger=logger, **kwargs)
    else:
        vr.simulate_fmu(first, logger=logger, **kwargs)
    gc.collect()
    print("first run's messages:", messages, flush=True)
    assert any("did not converge" in m for m in messages), messages
    sweep.main([second, "--grid", "debug_fail_after_time=0.55,5", "--steps", "4",
                "--scheduler", "synchronous", "--out", out])
    rows = (Path(out) / "sweep.csv").read_text().splitlines()
    print("sweep rows:", len(rows) - 1, flush=True)
    assert any(",discard," in r for r in rows) and any(",ok," in r for r in rows)
""")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    root = tmp_path_factory.mktemp("fmpy_logger")
    # Two different Velarium FMUs, each with a step that does not converge (debug switch).
    first = fs.debug_variant("PrestressedCable", root / "first", vr.VELARIUM, fail_after_time=0.6)
    second = fs.debug_variant("HenckyDisc", root / "second", vr.VELARIUM, fail_after_time=0.55)
    return first, second, root


def run(fmus, how: str):
    first, second, root = fmus
    out = root / f"sweep-{how}"
    return fs.run_python(SEQUENCE, str(first), str(second), str(out), how, timeout=600)


def test_fmpy_alone_crashes_in_the_later_sweep(fmus):
    r = run(fmus, "fmpy")
    if r.returncode == 0 and "sweep rows" in r.stdout:
        # A jump into freed memory is undefined behaviour: it faults on almost every run, but
        # once in a CI run on a heavily loaded machine the freed thunk was still intact and the
        # sequence finished. That run shows nothing about Velarium either way.
        pytest.skip("fmpy's freed logger thunk did not fault this time (undefined behaviour)")
    assert r.returncode < 0, f"expected the process to be killed by a signal:\n{r.stdout}\n{r.stderr}"
    # It got through the first run (and its Discard message) and died in the sweep.
    assert "first run's messages" in r.stdout and "sweep rows" not in r.stdout, r.stdout


def test_the_harness_wrapper_keeps_the_later_sweep_alive(fmus):
    r = run(fmus, "harness")
    assert r.returncode == 0, f"{r.stdout}\n{r.stderr}"
    assert "sweep rows: 9" in r.stdout, r.stdout
