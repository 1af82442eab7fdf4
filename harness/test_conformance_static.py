"""FMI 2.0 conformance checklist (docs/fmu.md, "The conformance checklist"), items 1-12: packaging, static
checks, loading and instantiation. One test per item, parametrised over every shipped FMU.

Error paths use fmpy's low-level ``FMU2Slave`` with explicit cleanup (``fmi_support.slave``);
messages are read from the recording logger of ``fmi_support``.
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import subprocess
import sys
import threading
import zipfile
from ctypes import byref, c_double, c_int, c_size_t, c_uint, c_void_p

import fmpy
import pytest

import fmi_support as fs
import velarium_run as vr

# The 34 functions of fmi2Functions.h a Co-Simulation FMU exports (common + CS).
FMI2_FUNCTIONS = sorted(
    """fmi2GetTypesPlatform fmi2GetVersion fmi2SetDebugLogging fmi2Instantiate fmi2FreeInstance
    fmi2SetupExperiment fmi2EnterInitializationMode fmi2ExitInitializationMode fmi2Terminate fmi2Reset
    fmi2GetReal fmi2GetInteger fmi2GetBoolean fmi2GetString fmi2SetReal fmi2SetInteger fmi2SetBoolean
    fmi2SetString fmi2GetFMUstate fmi2SetFMUstate fmi2FreeFMUstate fmi2SerializedFMUstateSize
    fmi2SerializeFMUstate fmi2DeSerializeFMUstate fmi2GetDirectionalDerivative
    fmi2SetRealInputDerivatives fmi2GetRealOutputDerivatives fmi2DoStep fmi2CancelStep fmi2GetStatus
    fmi2GetRealStatus fmi2GetIntegerStatus fmi2GetBooleanStatus fmi2GetStringStatus""".split()
)

# Shared libraries the FMU may need: the C runtime only (libpthread, libdl and librt are parts
# of glibc that a build against glibc < 2.34 names separately, e.g. the portable glibc 2.17
# build of harness/portable.sh, which links its unwinder statically and so needs no libgcc_s).
C_RUNTIME = re.compile(
    r"^(libc\.so\.6|libm\.so\.6|libgcc_s\.so\.1|ld-linux-x86-64\.so\.2|libpthread\.so\.0|libdl\.so\.2|librt\.so\.1)$")


def glibc_baseline() -> tuple[tuple[int, ...], str]:
    """The oldest glibc the packed library must load on (docs/fmu.md, "Portable FMUs"), and why:
    2.17 when the portable library is built and current (then `velarium pack` ships it by
    default), else 2.35 (the native build on Debian 12: `hypot@GLIBC_2.35`, objdump -T, 2026-11-29; 2.34 for
    its pthread and dlsym symbols); VELARIUM_GLIBC_BASELINE overrides."""
    given = os.environ.get("VELARIUM_GLIBC_BASELINE")
    if given:
        return tuple(int(x) for x in given.split(".")), "VELARIUM_GLIBC_BASELINE"
    if vr.portable_library_is_current():
        return (2, 17), f"the portable library {vr.PORTABLE_LIBRARY} is built"
    return (2, 35), f"no current portable library at {vr.PORTABLE_LIBRARY} (harness/portable.sh printed why): native build"


def highest_glibc(so) -> tuple[int, ...]:
    """The highest GLIBC_x.y symbol version the library needs (objdump -T)."""
    symbols = subprocess.run([tool("objdump"), "-T", str(so)], capture_output=True, text=True, check=True).stdout
    versions = sorted({tuple(int(x) for x in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", symbols)})
    assert versions, f"{so}: no GLIBC symbol version at all"
    return versions[-1]


def binary(fmu, md, tmp_path):
    path = tmp_path / f"{md.coSimulation.modelIdentifier}.so"
    path.write_bytes(vr.fmu_member(fmu, f"binaries/linux64/{md.coSimulation.modelIdentifier}.so"))
    return path


def tool(name: str):
    path = shutil.which(name)
    if path is None:
        pytest.skip(f"{name} (binutils) is not installed")
    return path


def test_item01_fmpy_validate_and_fmutool_check_pass(fmu):
    """`fmpy validate` exits 0 printing "No problems found."; `fmutool -check` exits 0."""
    fmpy_cli = vr.Path(sys.executable).with_name("fmpy")
    run = subprocess.run([str(fmpy_cli), "validate", str(fmu)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "No problems found." in run.stdout, run.stdout
    fmutool = vr.Path(sys.executable).with_name("fmutool")
    run = subprocess.run([str(fmutool), "-input", str(fmu), "-check"], capture_output=True, text=True, timeout=300)
    report = run.stdout + run.stderr
    assert run.returncode == 0, report
    assert "ERROR" not in report, report


def test_item02_zip_layout(fmu, model_description):
    """Deflate/store only, forward slashes, no symlinks, modelDescription.xml at the root, the
    binary under binaries/linux64/, and fmpy sees exactly the platform linux64."""
    with zipfile.ZipFile(fmu) as z:
        infos = z.infolist()
    names = [i.filename for i in infos]
    for i in infos:
        assert i.compress_type in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED), i.filename
        assert "\\" not in i.filename, i.filename
        assert not stat.S_ISLNK(i.external_attr >> 16), f"{i.filename} is a symlink"
    assert "modelDescription.xml" in names
    assert f"binaries/linux64/{model_description.coSimulation.modelIdentifier}.so" in names
    assert fmpy.supported_platforms(str(fmu)) == ["linux64"]


def test_item03_exports_dependencies_and_glibc(fmu, model_description, tmp_path):
    """nm: exactly the 34 fmi2 functions (and the 75 fmi3 functions of the FMI 3 archive, which
    holds the same library) are defined dynamic symbols; NEEDED: only the C runtime; objdump -T
    on the library of both archives (binaries/linux64 and binaries/x86_64-linux): no GLIBC
    symbol version above the baseline, 2.17 when the portable library was built (printed)."""
    from fmi3_support import FMI3_FUNCTIONS

    so = binary(fmu, model_description, tmp_path)
    nm = subprocess.run([tool("nm"), "-D", "--defined-only", str(so)], capture_output=True, text=True, check=True)
    exported = sorted(line.split()[-1] for line in nm.stdout.splitlines() if line.strip())
    expected = sorted(FMI2_FUNCTIONS + FMI3_FUNCTIONS)
    assert exported == expected, f"unexpected: {set(exported) - set(expected)}, missing: {set(expected) - set(exported)}"
    dynamic = subprocess.run([tool("objdump"), "-p", str(so)], capture_output=True, text=True, check=True).stdout
    needed = re.findall(r"NEEDED\s+(\S+)", dynamic)
    assert needed and all(C_RUNTIME.match(n) for n in needed), needed
    baseline, why = glibc_baseline()
    # Every archive of the scene: the FMI 2 one's binaries/linux64 and the FMI 3 one's
    # binaries/x86_64-linux (the same library, packed twice).
    libraries = [so]
    fmu3 = fmu.with_name(f"{fmu.stem}_fmi3.fmu")
    if fmu3.is_file():
        with zipfile.ZipFile(fmu3) as z:
            names = [n for n in z.namelist() if n.startswith("binaries/x86_64-linux/") and n.endswith(".so")]
        assert names, f"{fmu3.name} holds no binaries/x86_64-linux/*.so"
        for n in names:
            path = tmp_path / f"fmi3_{n.rsplit('/', 1)[-1]}"
            path.write_bytes(vr.fmu_member(fmu3, n))
            libraries.append(path)
    for lib in libraries:
        highest = highest_glibc(lib)
        print(f"{fmu.name} ({lib.name}): highest GLIBC symbol version needed: GLIBC_{'.'.join(map(str, highest))}; "
              f"baseline {'.'.join(map(str, baseline))} ({why}); dependencies: {needed}")
        assert highest <= baseline, (f"{lib.name} needs GLIBC_{'.'.join(map(str, highest))}, above the baseline "
                                     f"{'.'.join(map(str, baseline))} ({why}; docs/fmu.md)")


def test_item04_model_structure(fmu):
    """Every output once in <Outputs>; <InitialUnknowns> = outputs with initial calculated/approx
    plus calculatedParameters, sorted; every unit defined; parameters with explicit
    variability; no `initial` on inputs."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(vr.fmu_member(fmu, "modelDescription.xml"))
    variables = root.find("ModelVariables").findall("ScalarVariable")
    outputs = [i + 1 for i, v in enumerate(variables) if v.get("causality") == "output"]
    unknown_initial = [
        i + 1
        for i, v in enumerate(variables)
        if (v.get("causality") == "output" and v.get("initial", "calculated") in ("calculated", "approx"))
        or v.get("causality") == "calculatedParameter"
    ]
    structure = root.find("ModelStructure")
    listed_outputs = [int(u.get("index")) for u in structure.find("Outputs").findall("Unknown")]
    assert listed_outputs == outputs
    initial = structure.find("InitialUnknowns")
    listed_initial = [int(u.get("index")) for u in initial.findall("Unknown")] if initial is not None else []
    assert listed_initial == sorted(unknown_initial)
    defined = {u.get("name") for u in root.iter("Unit")}
    displays = {d.get("name") for d in root.iter("DisplayUnit")}
    for v in variables:
        value = v[0]
        assert value.get("unit") is None or value.get("unit") in defined, v.get("name")
        assert value.get("displayUnit") is None or value.get("displayUnit") in displays, v.get("name")
        if v.get("causality") == "parameter":
            assert v.get("variability") in ("fixed", "tunable"), v.get("name")
        if v.get("causality") == "input":
            assert v.get("initial") is None, v.get("name")


def test_item05_repackaged_with_another_guid_fails(fmu, model_description, tmp_path):
    """The GUID of modelDescription.xml is the one compiled into the binary+resources: the same
    FMU with only the GUID attribute changed fails to instantiate, naming both GUIDs."""
    unzipped = tmp_path / "repackaged"
    fmpy.extract(str(fmu), str(unzipped))
    xml_path = unzipped / "modelDescription.xml"
    other = "{12345678-9abc-def0-1234-56789abcdef0}"
    xml_path.write_text(xml_path.read_text().replace(model_description.guid, other))
    repackaged = fmpy.read_model_description(str(unzipped))
    assert repackaged.guid == other
    fs.clear_log()
    with fs.slave(unzipped, repackaged, instantiate=False) as s:
        with pytest.raises(Exception, match="Failed to instantiate"):
            s.instantiate(callbacks=fs.CALLBACKS)
    errors = " ".join(fs.messages(fs.ERROR))
    assert other in errors and model_description.guid in errors, errors
    # the untouched FMU instantiates with its own GUID
    with fs.slave(fmpy.extract(str(fmu), str(tmp_path / "original")), model_description) as s:
        assert s.component is not None


def test_item06_version_and_types_platform(unzipdir, model_description):
    with fs.slave(unzipdir, model_description, instantiate=False) as s:
        assert s.fmi2GetVersion().decode() == "2.0"
        assert s.fmi2GetTypesPlatform().decode() == "default"


def test_item07_wrong_guid_returns_null(unzipdir, model_description):
    """Instantiate with a wrong GUID: NULL (fmpy raises) and an Error message naming both GUIDs."""
    wrong = "{00000000-0000-0000-0000-000000000000}"
    fs.clear_log()
    with fs.slave(unzipdir, model_description, instantiate=False, guid=wrong, name="wrong_guid") as s:
        with pytest.raises(Exception, match="Failed to instantiate"):
            s.instantiate(callbacks=fs.CALLBACKS)
        assert s.component is None
    errors = fs.messages(fs.ERROR)
    assert any(wrong in m and model_description.guid in m for m in errors), errors


def raw_instantiate(s, md, name: bytes, fmu_type: int):
    uri = vr.Path(s.unzipDirectory, "resources").as_uri().encode()
    return s.fmi2Instantiate(name, fmu_type, md.guid.encode(), uri, byref(fs.CALLBACKS), 0, 0)


def test_item08_model_exchange_or_empty_name_returns_null(unzipdir, model_description):
    """fmuType = fmi2ModelExchange -> NULL with a message; empty instanceName -> NULL."""
    with fs.slave(unzipdir, model_description, instantiate=False) as s:
        fs.clear_log()
        assert raw_instantiate(s, model_description, b"me", 0) is None
        assert any("fmuType" in m for m in fs.messages(fs.ERROR)), fs.RECORDS
        fs.clear_log()
        assert raw_instantiate(s, model_description, b"", 1) is None
        assert any("instanceName" in m for m in fs.messages(fs.ERROR)), fs.RECORDS
        # the same call with a proper name works (so the NULLs above are about the arguments)
        c = raw_instantiate(s, model_description, b"ok", 1)
        assert c is not None
        s.fmi2FreeInstance(c)


def first_steps(s, md, steps=2):
    fs.initialize(s, md)
    return fs.ramp_run(s, md, steps)


def test_item09_resources_under_a_strange_directory(fmu, model_description, tmp_path):
    """Extracted under a directory whose name has spaces, `%`, `#` and non-ASCII characters: the
    percent-encoded URI is decoded, the scene is read, and the results equal a plain extraction."""
    strange = tmp_path / "tmp dir %20 %s #1" / "ä ø 漢"
    unzipped = fmpy.extract(str(fmu), str(strange))
    plain = fmpy.extract(str(fmu), str(tmp_path / "plain"))
    assert "%25" in vr.Path(unzipped, "resources").as_uri()
    with fs.slave(unzipped, model_description) as s:
        strange_rows = first_steps(s, model_description)
    with fs.slave(plain, model_description) as s:
        plain_rows = first_steps(s, model_description)
    assert strange_rows == plain_rows


def perturbed_parameters(md) -> dict[str, float]:
    """Every parameter 5 % below its start value (a valid, different model: moduli,
    thicknesses, pretensions, Poisson's ratios and friction coefficients stay in range)."""
    return {v.name: 0.95 * float(v.start) for v in md.modelVariables if v.causality == "parameter"}


def run_alone(unzipdir, md, values, scale, steps=3):
    with fs.slave(unzipdir, md) as s:
        fs.initialize(s, md, values=values)
        return scaled_ramp(s, md, steps, scale)


def scaled_ramp(s, md, steps, scale):
    table = vr.ramp_table(md, steps)
    refs = fs.real_output_refs(md)
    rows = [list(s.getReal(refs))]
    for k in range(steps):
        row = table[k].copy()
        for v in vr.inputs(md):
            row[v.name] = float(v.start) + scale * (row[v.name] - float(v.start))
        fs.set_inputs(s, md, row)
        t = float(table["time"][k])
        s.doStep(t, float(table["time"][k + 1]) - t)
        rows.append(list(s.getReal(refs)))
    return rows


def test_item10_two_instances_are_independent(unzipdir, model_description):
    """A (start values, full ramp) and B (parameters -5 %, half ramp) alone, then interleaved
    step by step in one process: the same numbers, bit for bit."""
    md, steps = model_description, 3
    a_alone = run_alone(unzipdir, md, {}, 1.0, steps)
    b_alone = run_alone(unzipdir, md, perturbed_parameters(md), 0.5, steps)
    assert a_alone != b_alone, "A and B must differ for the test to mean something"
    table = vr.ramp_table(md, steps)
    refs = fs.real_output_refs(md)
    with fs.slave(unzipdir, md, name="A") as a, fs.slave(unzipdir, md, name="B") as b:
        fs.initialize(a, md)
        fs.initialize(b, md, values=perturbed_parameters(md))
        rows = {id(a): [list(a.getReal(refs))], id(b): [list(b.getReal(refs))]}
        for k in range(steps):
            t, h = float(table["time"][k]), float(table["time"][k + 1] - table["time"][k])
            for s, scale in ((a, 1.0), (b, 0.5)):
                row = table[k].copy()
                for v in vr.inputs(md):
                    row[v.name] = float(v.start) + scale * (row[v.name] - float(v.start))
                fs.set_inputs(s, md, row)
                s.doStep(t, h)
                rows[id(s)].append(list(s.getReal(refs)))
        assert rows[id(a)] == a_alone
        assert rows[id(b)] == b_alone


def test_item11_ten_threads_equal_sequential_runs(unzipdir, model_description):
    """Ten instances (each its own load scale) stepped concurrently from ten Python threads
    (ctypes releases the GIL during the calls) give exactly the sequential results."""
    md, steps, n = model_description, 3, 10
    scales = [0.1 * (i + 1) for i in range(n)]
    sequential = [run_alone(unzipdir, md, {}, scale, steps) for scale in scales]
    results: list = [None] * n
    errors: list = []
    barrier = threading.Barrier(n)

    def work(i):
        try:
            with fs.slave(unzipdir, md, name=f"thread{i}") as s:
                fs.initialize(s, md)
                barrier.wait(timeout=60)
                results[i] = scaled_ramp(s, md, steps, scales[i])
        except Exception as e:  # reported below, in the main thread
            errors.append(f"thread {i}: {e!r}")

    threads = [threading.Thread(target=work, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=300)
    assert not errors, errors
    assert results == sequential


def test_item12_null_component(unzipdir, model_description):
    """fmi2FreeInstance(NULL) is a no-op; every one of the other 31 functions that take a
    component returns fmi2Error for a NULL component (raw ctypes calls, valid other arguments)."""
    from ctypes import c_char, c_char_p

    with fs.slave(unzipdir, model_description, instantiate=False) as s:
        s.fmi2FreeInstance(None)
        ref, real, integer, size = (c_uint * 1)(1), (c_double * 1)(), (c_int * 1)(), c_size_t()
        state, text, buffer = c_void_p(), (c_char_p * 1)(b"x"), (c_char_p * 1)()
        blob = (c_char * 64)()
        calls = {
            "fmi2SetDebugLogging": (0, 0, None),
            "fmi2SetupExperiment": (0, 0.0, 0.0, 0, 0.0),
            "fmi2EnterInitializationMode": (),
            "fmi2ExitInitializationMode": (),
            "fmi2Terminate": (),
            "fmi2Reset": (),
            "fmi2GetReal": (ref, 1, real),
            "fmi2GetInteger": (ref, 1, integer),
            "fmi2GetBoolean": (ref, 1, integer),
            "fmi2GetString": (ref, 1, buffer),
            "fmi2SetReal": (ref, 1, real),
            "fmi2SetInteger": (ref, 1, integer),
            "fmi2SetBoolean": (ref, 1, integer),
            "fmi2SetString": (ref, 1, text),
            "fmi2GetFMUstate": (byref(state),),
            "fmi2SetFMUstate": (state,),
            "fmi2FreeFMUstate": (byref(state),),
            "fmi2SerializedFMUstateSize": (state, byref(size)),
            "fmi2SerializeFMUstate": (state, blob, 64),
            "fmi2DeSerializeFMUstate": (blob, 64, byref(state)),
            "fmi2GetDirectionalDerivative": (ref, 1, ref, 1, real, real),
            "fmi2SetRealInputDerivatives": (ref, 1, integer, real),
            "fmi2GetRealOutputDerivatives": (ref, 1, integer, real),
            "fmi2DoStep": (0.0, 0.1, 1),
            "fmi2CancelStep": (),
            "fmi2GetStatus": (0, integer),
            "fmi2GetRealStatus": (2, real),
            "fmi2GetIntegerStatus": (0, integer),
            "fmi2GetBooleanStatus": (3, integer),
            "fmi2GetStringStatus": (0, buffer),
        }
        for name, args in calls.items():
            assert fs.status_of(getattr(s, name), None, *args) == fs.ERROR, name
        assert len(calls) == len(FMI2_FUNCTIONS) - 4  # all but GetTypesPlatform, GetVersion, Instantiate, FreeInstance
