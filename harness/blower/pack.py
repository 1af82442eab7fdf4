"""Build the Blower FMUs (blower.c) into DIR/Blower.fmu (FMI 2.0 Co-Simulation) and
DIR/Blower_fmi3.fmu (FMI 3.0 Co-Simulation, the same library).

    python3 harness/blower/pack.py [DIR]        # default build/fmus

Needs a C compiler (`cc`) and nothing else: the library links libc and libm only. Takes well
under a second; the archive is rebuilt only when blower.c or this file is newer than it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
GUID = "{5b1c3e0a-7f2d-4c59-9a3e-b10e3c0a5e10}"

# (name, value reference, causality, variability, start, unit, description)
VARIABLES = [
    ("V", 0, "input", "continuous", 1.0, "m3", "volume of the cushion"),
    ("p_set", 1, "input", "continuous", 0.0, "Pa", "pressure set point of the controller (gauge)"),
    ("p", 2, "output", "continuous", None, "Pa", "pressure in the cushion (gauge)"),
    ("N", 3, "output", "continuous", None, "m3", "gas in the cushion as its volume at the atmosphere's pressure"),
    ("u", 4, "output", "continuous", None, "1", "valve opening, 0 closed to 1 open"),
    ("Q_fan", 5, "output", "continuous", None, "m3/s", "fan's volume flow (at the atmosphere's pressure)"),
    ("Q_valve", 6, "output", "continuous", None, "m3/s", "valve's volume flow (at the atmosphere's pressure)"),
    ("dN", 7, "output", "continuous", None, "m3", "N - N_ref: with N_ref the cushion's reference volume, Velarium's gas input"),
    ("p_atm", 10, "parameter", "fixed", 101325.0, "Pa", "absolute pressure of the atmosphere"),
    ("dp0", 11, "parameter", "fixed", 1500.0, "Pa", "fan's shut-off pressure rise"),
    ("Q_max", 12, "parameter", "fixed", 0.2, "m3/s", "fan's free-delivery flow"),
    ("fan_shape", 13, "parameter", "fixed", 0.5, "1", "fan curve dp0 (1 - a q - (1 - a) q^2), q = Q/Q_max: a"),
    ("K_valve", 14, "parameter", "fixed", 0.02, "m3/(s.Pa0.5)", "valve's flow coefficient: Q = u K p / sqrt(|p| + p_lam)"),
    ("p_lam", 15, "parameter", "fixed", 10.0, "Pa", "valve's laminar regularisation pressure"),
    ("Kp", 16, "parameter", "fixed", 2e-3, "1/Pa", "controller's proportional gain on p - p_set"),
    ("Ki", 17, "parameter", "fixed", 2e-3, "1/(Pa.s)", "controller's integral gain"),
    ("u0", 18, "parameter", "fixed", 0.5, "1", "valve opening at zero error and zero integral"),
    ("V0", 19, "parameter", "fixed", 1.0, "m3", "cushion's volume at the start"),
    ("p0", 20, "parameter", "fixed", 0.0, "Pa", "cushion's pressure at the start (gauge)"),
    ("N_ref", 21, "parameter", "fixed", 0.0, "m3", "reference of the output dN = N - N_ref"),
]


def model_description() -> str:
    units = sorted({v[5] for v in VARIABLES})
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<fmiModelDescription fmiVersion="2.0" modelName="Blower" guid="%s"' % GUID,
        '  description="A cushion\'s air supply: a fan with a fan curve and a relief valve under a PI pressure'
        ' controller, isothermal ideal gas; input the cushion\'s volume, output its pressure (Velarium repository, harness/blower/)"',
        '  generationTool="velarium harness/blower/pack.py" variableNamingConvention="flat" numberOfEventIndicators="0">',
        '  <CoSimulation modelIdentifier="Blower" canHandleVariableCommunicationStepSize="true"'
        ' canGetAndSetFMUstate="true" canSerializeFMUstate="true" providesDirectionalDerivative="true"'
        ' canNotUseMemoryManagementFunctions="true"/>',
        "  <UnitDefinitions>",
    ]
    lines += ['    <Unit name="%s"/>' % u for u in units]
    lines += ["  </UnitDefinitions>", "  <DefaultExperiment startTime=\"0\" stopTime=\"10\" stepSize=\"0.1\"/>",
              "  <ModelVariables>"]
    for name, vr, caus, var, start, unit, desc in VARIABLES:
        attrs = 'name="%s" valueReference="%d" causality="%s" variability="%s"' % (name, vr, caus, var)
        if caus == "parameter":
            attrs += ' initial="exact"'
        real = '<Real unit="%s"%s/>' % (unit, "" if start is None else ' start="%r"' % start)
        lines.append('    <ScalarVariable %s description="%s">%s</ScalarVariable>' % (attrs, desc, real))
    index = {v[0]: k + 1 for k, v in enumerate(VARIABLES)}
    lines += ["  </ModelVariables>", "  <ModelStructure>", "    <Outputs>"]
    for name in ("p", "N", "u", "Q_fan", "Q_valve", "dN"):
        lines.append('      <Unknown index="%d" dependencies="%d %d"/>' % (index[name], index["V"], index["p_set"]))
    lines += ["    </Outputs>", "    <InitialUnknowns>"]
    for name in ("p", "N", "u", "Q_fan", "Q_valve", "dN"):
        lines.append('      <Unknown index="%d"/>' % index[name])
    lines += ["    </InitialUnknowns>", "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


BASE_UNITS = {"m3": 'm="3"', "Pa": 'kg="1" m="-1" s="-2"', "1": "", "m3/s": 'm="3" s="-1"',
              "m3/(s.Pa0.5)": None, "1/Pa": 'kg="-1" m="1" s="2"', "1/(Pa.s)": 'kg="-1" m="1" s="1"', "s": 's="1"'}


def model_description_3() -> str:
    units = sorted({v[5] for v in VARIABLES} | {"s"})
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<fmiModelDescription fmiVersion="3.0" modelName="Blower" instantiationToken="%s"' % GUID,
        '  description="A cushion\'s air supply: a fan with a fan curve and a relief valve under a PI pressure'
        ' controller, isothermal ideal gas; input the cushion\'s volume, output its pressure (Velarium repository, harness/blower/)"',
        '  generationTool="velarium harness/blower/pack.py" variableNamingConvention="flat">',
        '  <CoSimulation modelIdentifier="Blower" canHandleVariableCommunicationStepSize="true"'
        ' canGetAndSetFMUState="true" canSerializeFMUState="true" providesDirectionalDerivatives="true"'
        ' providesAdjointDerivatives="true" hasEventMode="false"/>',
        "  <UnitDefinitions>",
    ]
    for u in units:
        base = BASE_UNITS.get(u)
        lines.append('    <Unit name="%s">%s</Unit>' % (u, "" if base is None else "<BaseUnit %s/>" % base))
    lines += ["  </UnitDefinitions>", '  <DefaultExperiment startTime="0" stopTime="10" stepSize="0.1"/>',
              "  <ModelVariables>",
              '    <Float64 name="time" valueReference="999" causality="independent" variability="continuous"'
              ' unit="s" description="simulation time"/>']
    for name, vr, caus, var, start, unit, desc in VARIABLES:
        attrs = 'name="%s" valueReference="%d" causality="%s" variability="%s" unit="%s"' % (name, vr, caus, var, unit)
        if start is not None:
            attrs += ' start="%r"' % start
        lines.append('    <Float64 %s description="%s"/>' % (attrs, desc))
    lines += ["  </ModelVariables>", "  <ModelStructure>"]
    for name in ("p", "N", "u", "Q_fan", "Q_valve", "dN"):
        vr = next(v[1] for v in VARIABLES if v[0] == name)
        lines.append('    <Output valueReference="%d" dependencies="0 1"/>' % vr)
    for name in ("p", "N", "u", "Q_fan", "Q_valve", "dN"):
        vr = next(v[1] for v in VARIABLES if v[0] == name)
        lines.append('    <InitialUnknown valueReference="%d"/>' % vr)
    lines += ["  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def pack(out_dir: str | os.PathLike = "build/fmus", cc: str | None = None) -> Path:
    """Compile blower.c and write OUT_DIR/Blower.fmu and OUT_DIR/Blower_fmi3.fmu; returns the
    FMI 2 archive's path."""
    out = Path(out_dir) / "Blower.fmu"
    out3 = out.with_name("Blower_fmi3.fmu")
    sources = [HERE / "blower.c", Path(__file__).resolve()]
    if out.exists() and out3.exists() and all(
            min(out.stat().st_mtime, out3.stat().st_mtime) >= s.stat().st_mtime for s in sources):
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    cc = cc or os.environ.get("CC", "cc")
    with tempfile.TemporaryDirectory() as tmp:
        lib = Path(tmp) / "Blower.so"
        subprocess.run([cc, "-O2", "-std=c99", "-D_DEFAULT_SOURCE", "-Wall", "-Wextra", "-shared", "-fPIC",
                        "-fvisibility=hidden", "-o", str(lib), str(HERE / "blower.c"), "-lm"], check=True)
        for target, md, platform in ((out, model_description(), "linux64"),
                                     (out.with_name("Blower_fmi3.fmu"), model_description_3(), "x86_64-linux")):
            part = target.with_suffix(".fmu.part")
            with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
                z.writestr("modelDescription.xml", md)
                z.write(lib, f"binaries/{platform}/Blower.so")
                z.write(HERE / "blower.c", "sources/blower.c")
            part.replace(target)
    return out


if __name__ == "__main__":
    print(pack(sys.argv[1] if len(sys.argv) > 1 else "build/fmus"))
