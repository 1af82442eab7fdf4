"""A coupled system as an SSP 1.0 package (docs/coupling.md, "SSP"): ``SystemStructure.ssd``
and the FMUs under ``resources/``.

- the FMUs are SSD components (``application/x-fmu-sharedlibrary``), their connections SSD
  connections, their start values inline parameter sets (``ssv:ParameterSet``) in the
  components' parameter bindings (a start value that names another FMU's output is resolved to
  its number when the package is written);
- the external inputs are input connectors of the system, connected to the components' inputs;
  the values the monolithic reference compares (``monolithic.compare``) are output connectors of
  the system, connected from the component outputs that carry them (an input such as
  ``cushion.p`` from the output that feeds it), so that another tool's result holds them; the
  inputs' time tables, the macro step and the monolithic reference (tool-specific data SSP has no
  element for) are an annotation of the default experiment, type ``org.velarium.couple``,
  holding JSON in a ``vc:Couple`` element (namespace ``urn:velarium:couple:1``).

``write_ssp(system, out)`` writes a package from a loaded system file (``couple.load_system``);
``read_ssp(path)`` reads one back into the same form, so ``run_system`` runs either.
"""

from __future__ import annotations

import json
import shutil
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from typing import Any, Mapping

from .couple import CouplingError, Unit

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
ANNOTATION = "org.velarium.couple"
VC = "urn:velarium:couple:1"


def _q(ns: str, tag: str) -> str:
    return f"{{{ns}}}{tag}"


def _resolved_starts(sysd: Mapping[str, Any]) -> dict[str, dict[str, float]]:
    """Start values with "fmu.var" references replaced by that FMU's output after its
    initialization (with its own start values and the external inputs at t = 0)."""
    out: dict[str, dict[str, float]] = {}
    for name, spec in sysd["fmus"].items():
        vals = {}
        for k, v in spec.get("start", {}).items():
            if isinstance(v, str):
                other, _, var = v.partition(".")
                if other not in sysd["fmus"]:
                    raise CouplingError(f"fmus.{name}.start.{k}: {v} names no FMU")
                u = Unit(other, sysd["fmu_paths"][other], {})
                try:
                    ext = {key.split(".", 1)[1]: float(json_interp(tab, 0.0))
                           for key, tab in sysd.get("inputs", {}).items() if key.split(".", 1)[0] == other}
                    u.initialize(0.0, {**out.get(other, {}), **ext})
                    v = float(u.get([var])[0])
                finally:
                    u.close()
            vals[k] = float(v)
        out[name] = vals
    return out


def json_interp(table, t: float) -> float:
    import numpy as np

    a = np.asarray(table, dtype=float)
    return float(np.interp(t, a[:, 0], a[:, 1]))


def write_ssp(sysd: Mapping[str, Any], out: str | Path, name: str = "System") -> Path:
    """Write the loaded system ``sysd`` as an SSP 1.0 package ``out``."""
    out = Path(out)
    ET.register_namespace("ssd", SSD)
    ET.register_namespace("ssc", SSC)
    ET.register_namespace("ssv", SSV)
    root = ET.Element(_q(SSD, "SystemStructureDescription"), {"version": "1.0", "name": name})
    system = ET.SubElement(root, _q(SSD, "System"), {"name": name})
    inputs = sysd.get("inputs", {})
    # one system connector per external input, named fmu_var
    ext_names = {key: key.replace(".", "_") for key in inputs}
    conns = [tuple(c) for c in sysd["connections"]]
    fed_by = {b: a for a, b in conns}
    # one system output per compared value, named fmu_var, from the output that carries it
    out_names = {key: fed_by.get(key, key) for key in sysd.get("monolithic", {}).get("compare", {})}
    if ext_names or out_names:
        sc = ET.SubElement(system, _q(SSD, "Connectors"))
        for key, n in ext_names.items():
            ET.SubElement(ET.SubElement(sc, _q(SSD, "Connector"), {"name": n, "kind": "input"}), _q(SSC, "Real"))
        for key in out_names:
            ET.SubElement(ET.SubElement(sc, _q(SSD, "Connector"), {"name": key.replace(".", "_"), "kind": "output"}),
                          _q(SSC, "Real"))
    elements = ET.SubElement(system, _q(SSD, "Elements"))
    starts = _resolved_starts(sysd)
    resources = {}
    for fname in sysd["fmus"]:
        path = Path(sysd["fmu_paths"][fname])
        source = f"resources/{path.name}"
        resources[source] = path
        comp = ET.SubElement(elements, _q(SSD, "Component"),
                             {"name": fname, "type": "application/x-fmu-sharedlibrary", "source": source})
        cc = ET.SubElement(comp, _q(SSD, "Connectors"))
        seen = set()
        for a, b in conns:
            for end, kind in ((a, "output"), (b, "input")):
                u, _, v = end.partition(".")
                if u == fname and v not in seen:
                    seen.add(v)
                    ET.SubElement(ET.SubElement(cc, _q(SSD, "Connector"), {"name": v, "kind": kind}), _q(SSC, "Real"))
        for key in list(inputs) + list(out_names.values()):
            u, _, v = key.partition(".")
            kind = "input" if key in inputs else "output"
            if u == fname and v not in seen:
                seen.add(v)
                ET.SubElement(ET.SubElement(cc, _q(SSD, "Connector"), {"name": v, "kind": kind}), _q(SSC, "Real"))
        if starts.get(fname):
            pb = ET.SubElement(ET.SubElement(comp, _q(SSD, "ParameterBindings")), _q(SSD, "ParameterBinding"))
            pv = ET.SubElement(pb, _q(SSD, "ParameterValues"))
            ps = ET.SubElement(pv, _q(SSV, "ParameterSet"), {"version": "1.0", "name": f"{fname}_start"})
            params = ET.SubElement(ps, _q(SSV, "Parameters"))
            for k, v in starts[fname].items():
                ET.SubElement(ET.SubElement(params, _q(SSV, "Parameter"), {"name": k}), _q(SSV, "Real"), {"value": repr(v)})
    cs = ET.SubElement(system, _q(SSD, "Connections"))
    for a, b in conns:
        ua, _, va = a.partition(".")
        ub, _, vb = b.partition(".")
        ET.SubElement(cs, _q(SSD, "Connection"),
                      {"startElement": ua, "startConnector": va, "endElement": ub, "endConnector": vb})
    for key, n in ext_names.items():
        u, _, v = key.partition(".")
        ET.SubElement(cs, _q(SSD, "Connection"), {"startConnector": n, "endElement": u, "endConnector": v})
    for key, source in out_names.items():
        u, _, v = source.partition(".")
        ET.SubElement(cs, _q(SSD, "Connection"),
                      {"startElement": u, "startConnector": v, "endConnector": key.replace(".", "_")})
    exp = ET.SubElement(root, _q(SSD, "DefaultExperiment"), {"startTime": "0", "stopTime": repr(float(sysd["stop"]))})
    data: dict[str, Any] = {"step": sysd["step"], "inputs": {ext_names[k]: v for k, v in inputs.items()}}
    for key in ("options", "description"):
        if key in sysd:
            data[key] = sysd[key]
    if "monolithic" in sysd:
        mono = {k: v for k, v in sysd["monolithic"].items() if k not in ("fmu_path", "scene", "fmu")}
        mpath = Path(sysd["monolithic"]["fmu_path"])
        mono["fmu"] = f"resources/{mpath.name}"
        resources[mono["fmu"]] = mpath
        data["monolithic"] = mono
    ann = ET.SubElement(ET.SubElement(exp, _q(SSD, "Annotations")), _q(SSC, "Annotation"), {"type": ANNOTATION})
    ET.register_namespace("vc", VC)
    ET.SubElement(ann, _q(VC, "Couple")).text = json.dumps(data)
    ET.indent(root)
    out.parent.mkdir(parents=True, exist_ok=True)
    part = out.with_suffix(out.suffix + ".part")
    with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd", ET.tostring(root, encoding="unicode", xml_declaration=True))
        for arc, p in resources.items():
            z.write(p, arc)
    part.replace(out)
    return out


def read_ssp(path: str | Path, directory: str | Path | None = None) -> dict[str, Any]:
    """Read an SSP package written by ``write_ssp`` (or any SSP 1.0 package of two FMU
    components with Real connections) into the form of ``couple.load_system``; the archive is
    extracted into ``directory`` (a new temporary one by default)."""
    path = Path(path)
    directory = Path(directory or tempfile.mkdtemp(prefix="couple-ssp-"))
    try:
        with zipfile.ZipFile(path) as z:
            z.extractall(directory)
    except (OSError, zipfile.BadZipFile) as e:
        raise CouplingError(f"{path}: {e}") from None
    ssd_file = directory / "SystemStructure.ssd"
    if not ssd_file.exists():
        raise CouplingError(f"{path}: no SystemStructure.ssd")
    root = ET.parse(ssd_file).getroot()
    system = root.find(_q(SSD, "System"))
    if system is None:
        raise CouplingError(f"{path}: SystemStructure.ssd has no ssd:System")
    fmus, fmu_paths = {}, {}
    for comp in system.iterfind(f"{_q(SSD, 'Elements')}/{_q(SSD, 'Component')}"):
        name, source = comp.get("name"), comp.get("source")
        if not name or not source:
            raise CouplingError(f"{path}: a component without name or source")
        start = {}
        for p in comp.iterfind(f".//{_q(SSV, 'Parameter')}"):
            real = p.find(_q(SSV, "Real"))
            if real is not None:
                start[p.get("name")] = float(real.get("value"))
        fmus[name] = {"fmu": source, "start": start}
        fmu_paths[name] = directory / source
    exp = root.find(_q(SSD, "DefaultExperiment"))
    data: dict[str, Any] = {}
    if exp is not None:
        for ann in exp.iter(_q(SSC, "Annotation")):
            body = ann.find(_q(VC, "Couple"))
            if ann.get("type") == ANNOTATION and body is not None:
                data = json.loads(body.text or "{}")
    connections, external = [], {}
    for c in system.iterfind(f"{_q(SSD, 'Connections')}/{_q(SSD, 'Connection')}"):
        se, sc, ee, ec = (c.get(k) for k in ("startElement", "startConnector", "endElement", "endConnector"))
        if se is None:
            external[sc] = f"{ee}.{ec}"
        elif ee is None:
            continue  # a system output (a compared value, for other tools' results)
        else:
            connections.append([f"{se}.{sc}", f"{ee}.{ec}"])
    inputs = {}
    for conn_name, table in data.get("inputs", {}).items():
        if conn_name not in external:
            raise CouplingError(f"{path}: the annotation's input {conn_name} is not connected to a component")
        inputs[external[conn_name]] = table
    if "step" not in data:
        raise CouplingError(f"{path}: no macro step (annotation {ANNOTATION} of the DefaultExperiment)")
    sysd: dict[str, Any] = {
        "fmus": fmus, "fmu_paths": fmu_paths, "connections": connections, "inputs": inputs,
        "step": data["step"], "stop": float(exp.get("stopTime")), "ssp_directory": directory,
    }
    if "options" in data:
        sysd["options"] = data["options"]
    if "monolithic" in data:
        mono = dict(data["monolithic"])
        mono["fmu_path"] = directory / mono.pop("fmu")
        sysd["monolithic"] = mono
    return sysd


def remove(sysd: Mapping[str, Any]) -> None:
    """Remove the extracted package of ``read_ssp``."""
    d = sysd.get("ssp_directory")
    if d:
        shutil.rmtree(d, ignore_errors=True)
