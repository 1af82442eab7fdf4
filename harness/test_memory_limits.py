"""Issue 11 through an FMU: an allocation that fails after the size limits passed is an error
inside the host, never an abort of it.

A 40-ring Hencky disc (4,921 nodes, 14,283 unknowns) is packed with limits that let it through
whatever the process can get (``max_memory_gb`` 1000, ``check_available_memory`` false). A fresh
Python process loads the FMU with fmpy, then lowers its own address-space limit with
``resource.setrlimit(RLIMIT_AS)`` to what it has mapped plus ``extra`` MB, and instantiates,
initializes and takes one step under the full pressure. Over a sweep of ``extra`` from 0 to
enough, every process must exit normally (return code 0: no SIGABRT, no SIGSEGV), reporting
one of: Instantiate returned NULL with an Error logged that says "out of memory", DoStep
returned Discard or Error with such a message logged, or the step converged. Both ends must
occur (an out-of-memory report at the low levels, a converged step at the high ones), and in
between an instantiated FMU whose step cannot get its working memory returns Discard (measured
at 48 MB: "out of memory: 4.6 MB for the step's working memory").

With ``debug.skip_memory_probes`` the sweep stops after Instantiate: without the probes the
fallible allocations themselves meet the limit (the mesh, the model, the pattern, the factor,
the workspaces: src/memory.rs) and each must come back as NULL with the allocation named.
"""

from __future__ import annotations

import json
import re
import textwrap

import pytest

import fmi_support as fs
import velarium_run as vr

CHILD = textwrap.dedent("""
    import resource, sys
    import fmpy
    import fmi_support as fs
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    fmu_path, extra_mb, step = sys.argv[1], float(sys.argv[2]), sys.argv[3] == "step"
    md = fmpy.read_model_description(fmu_path)
    unzipdir = fmpy.extract(fmu_path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="limited")
    pressure = [v.valueReference for v in md.modelVariables if v.name == "pressure"][0]
    mapped = int(open("/proc/self/statm").read().split()[0]) * resource.getpagesize()
    limit = mapped + int(extra_mb * 2**20)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    def errors():
        return " | ".join(m.replace(chr(10), " ") for _, s, _, m in fs.RECORDS if s >= fs.DISCARD)
    try:
        fmu.instantiate(callbacks=fs.CALLBACKS)
    except Exception as e:
        print("OUTCOME instantiate-null:", errors(), flush=True)
        sys.exit(0)
    if not step:
        print("OUTCOME instantiated", flush=True)
        sys.exit(0)
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.setReal([pressure], [400.0])
        fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1.0)
        print("OUTCOME converged", flush=True)
    except FMICallException as e:
        print(f"OUTCOME status-{e.status}:", errors(), flush=True)
    sys.exit(0)
""")


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    root = tmp_path_factory.mktemp("memory")
    out = {}
    for skip in (False, True):
        scene = json.loads((vr.SCENES / "HenckyDisc" / "scene.json").read_text())
        scene["geometry"]["generators"][0]["rings"] = 40
        scene["solver"] = {**scene.get("solver", {}),
                           "limits": {"max_memory_gb": 1000, "check_available_memory": False}}
        if skip:
            scene["debug"] = {"skip_memory_probes": True}
        d = root / ("skip" if skip else "probes")
        d.mkdir()
        (d / "scene.json").write_text(json.dumps(scene))
        run = fs.subprocess.run([str(vr.VELARIUM), "pack", str(d / "scene.json"), "--out", str(d), "--fmi", "2"],
                                capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        out[skip] = d / "HenckyDisc.fmu"
    return out


def sweep(fmu, levels, step: bool) -> list[str]:
    outcomes = []
    for extra in levels:
        r = fs.run_python(CHILD, str(fmu), str(extra), "step" if step else "instantiate", timeout=300)
        line = next((l for l in r.stdout.splitlines() if l.startswith("OUTCOME")), None)
        assert r.returncode == 0 and line, (
            f"{extra} MB above the mapped size: exit {r.returncode} (a negative code is a signal)\n"
            f"{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
        outcome = line.removeprefix("OUTCOME ")
        if not outcome.startswith(("converged", "instantiated")):
            assert "out of memory" in outcome, f"{extra} MB: {outcome}"
        outcomes.append(outcome)
        print(f"{extra:5.0f} MB: {outcome[:160]}")
    return outcomes


def test_instantiate_and_step_under_a_low_address_space_limit_end_in_errors_not_aborts(variants):
    outcomes = sweep(variants[False], range(0, 161, 8), step=True)
    assert any(o.startswith("instantiate-null") for o in outcomes), outcomes
    assert any(o == "converged" for o in outcomes), outcomes
    # Between the two, a step whose memory is not there is a Discard with the message logged
    # (`sweep` asserts "out of memory" in every outcome that is not a success). Since the merge
    # of issue 13 the instantiation probe (42.5 MB here) leaves room for this scene's step
    # (4.6 MB), so no level of this sweep lands in that window (scanned in 2 MB steps from 36
    # to 70 MB on 2026-11-23: none). A test that reaches the step's own probe through an FMU
    # is open work (issue 11 note).


def test_each_fallible_allocation_fails_instantiate_with_its_name(variants):
    outcomes = sweep(variants[True], range(0, 81, 4), step=False)
    sites = set()
    for o in outcomes:
        sites.update(re.findall(r"MB for (.+?) could not be allocated", o))
    print("sites:", sorted(sites))
    assert any(o == "instantiated" for o in outcomes), outcomes
    assert len(sites) >= 5, sites  # measured: 7
