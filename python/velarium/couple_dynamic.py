"""The cushion-and-blower system with the cushion's mass (docs/coupling.md, "The dynamic system").

The quasi-static example's two cushion scenes (``cushion_pressure.json``, ``cushion_gas.json``)
gain a ``dynamics`` section: the foil's density, Rayleigh mass-proportional damping and
generalized-alpha time integration, so that a cushion step advances physical time (the skins
accelerate under the pressure difference instead of jumping to equilibrium). The blower already
integrates its own dynamics (the gas amount N and the controller's integral I, backward Euler).
Everything else of the system file (connections, inputs, start values, the monolithic entry) is
kept, so the master and the monolithic reference (``couple_monolithic.solve``, which steps the
``gas`` scene from its saved states and so integrates the same dynamics) run it unchanged.

    from velarium import couple, couple_dynamic
    sysd = couple_dynamic.load_dynamic_system("examples/coupling/cushion_blower.json", "build/coupling")

``gas_amount_system`` rewires such a system through the gas amount instead of the pressure (the
cushion's `gas` scene takes the blower's ``dN``): the gas law then holds in every one of the
cushion's sub-steps, which keeps the coupling stable with sub-steps inside the macro step
(docs/coupling.md, "The remedy: the gas law inside the sub-steps").
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any, Mapping

from . import couple

#: ETFE's density (kg/m³): a 0.2 mm foil weighs 0.35 kg/m²
DENSITY = 1750.0
#: mass-proportional Rayleigh damping (1/s)
RAYLEIGH_ALPHA = 20.0
#: generalized-alpha's spectral radius at infinite frequency
RHO_INF = 0.9


def dynamic_scene(scene: Mapping[str, Any], density: float = DENSITY, rayleigh_alpha: float = RAYLEIGH_ALPHA,
                  rho_inf: float = RHO_INF, max_time_step: float | None = None) -> dict[str, Any]:
    """A copy of a quasi-static scene with every membrane's density and a ``dynamics`` section."""
    out = copy.deepcopy(dict(scene))
    out["name"] = out["name"] + "Dynamic"
    for m in out.get("membranes", []):
        m["density"] = density
    ti: dict[str, Any] = {"rho_inf": rho_inf}
    if max_time_step is not None:
        ti["max_time_step"] = max_time_step
    out["dynamics"] = {"mass": "consistent", "rayleigh_alpha": rayleigh_alpha, "time_integration": ti}
    return out


def load_dynamic_system(path: str | Path, build: str | Path = "build/coupling", fmi: int | None = None,
                        **dynamics: Any) -> dict[str, Any]:
    """``couple.load_system`` of a system file whose Velarium scenes (the FMUs' and the monolithic
    reference's) are replaced by their dynamic versions (``dynamic_scene``; keyword arguments go
    to it), written and packed into ``build``."""
    path = Path(path).resolve()
    sysd = json.loads(path.read_text())
    build = Path(build).resolve()
    build.mkdir(parents=True, exist_ok=True)

    def convert(spec: dict[str, Any]) -> None:
        if "scene" in spec:
            scene = json.loads((path.parent / spec["scene"]).read_text())
            dyn = dynamic_scene(scene, **dynamics)
            out = build / (Path(spec["scene"]).stem + "_dynamic.json")
            out.write_text(json.dumps(dyn))
            spec["scene"] = str(out)

    for spec in sysd["fmus"].values():
        convert(spec)
    static_gas = None
    if "monolithic" in sysd:
        static_gas = couple._fmu_path("monolithic", dict(sysd["monolithic"]), path.parent, build, fmi)
        convert(sysd["monolithic"])
    for spec in sysd["fmus"].values():  # archives relative to the original file
        if "fmu" in spec:
            spec["fmu"] = str((path.parent / spec["fmu"]).resolve())
    tmp = build / (path.stem + "_dynamic.json")
    tmp.write_text(json.dumps(sysd))
    out = couple.load_system(tmp, build, fmi)
    if static_gas is not None:
        out["monolithic"]["static_fmu_path"] = static_gas
    return out


def monolithic(sysd: Mapping[str, Any], step: float | None = None) -> dict[str, Any]:
    """The monolithic answer of a dynamic system (``load_dynamic_system``): the dynamic ``gas``
    scene stepped with the blower's balance solved around it (``couple_monolithic.solve``),
    started from the static equilibrium at the system's p0 as the coupled cushion starts."""
    from . import couple_monolithic as cm

    mono = sysd["monolithic"]
    blower = mono["blower"]
    par = cm.blower_parameters(sysd["fmu_paths"][blower],
                               {k: v for k, v in sysd["fmus"][blower].get("start", {}).items()
                                if not isinstance(v, str)})
    inputs = sysd.get("inputs", {})
    initial = cm.initial_gas(mono["static_fmu_path"], par, float(mono["p0"]), inputs[mono["snow"]])
    return cm.solve(mono["fmu_path"], par, float(mono["p0"]), inputs[mono["p_set"]], inputs[mono["snow"]],
                    float(sysd["stop"]), float(step or sysd["step"]), initial=initial)


def gas_amount_system(sysd: Mapping[str, Any]) -> dict[str, Any]:
    """The system ``sysd`` (``load_dynamic_system`` of the cushion-and-blower example, or any
    system with the same ``monolithic`` entry) coupled through the gas amount: the cushion is
    the `gas` scene of its monolithic entry, wired ``cushion.V -> blower.V`` and
    ``blower.dN -> cushion.<gas input>``, started at the gas amount that holds p0 at rest
    (``couple_monolithic.initial_gas``, as the monolithic reference starts), the blower's
    ``N_ref`` the scene's reference volume V⁰ (so that its ``dN`` = N − V⁰ is the scene's ΔN)
    and its start the cushion's initial V and p. Inputs, stop and step as in ``sysd``; the
    result runs in ``couple.Master`` like any system (``couple.run_system``)."""
    from . import couple_monolithic as cm

    mono = sysd["monolithic"]
    blower = mono["blower"]
    cushion = next(n for n in sysd["fmus"] if n != blower)
    path = sysd["fmu_paths"][blower]
    par = cm.blower_parameters(path)
    dn0, v_ref = cm.initial_gas(mono["static_fmu_path"], par, float(mono["p0"]), sysd["inputs"][mono["snow"]])
    return {
        "fmus": {cushion: {"start": {"dN": dn0}},
                 blower: {"start": {"V0": f"{cushion}.V", "p0": f"{cushion}.p", "N_ref": v_ref}}},
        "fmu_paths": {cushion: mono["fmu_path"], blower: path},
        "connections": [[f"{cushion}.V", f"{blower}.V"], [f"{blower}.dN", f"{cushion}.dN"]],
        "inputs": dict(sysd.get("inputs", {})),
        "stop": sysd["stop"],
        "step": sysd["step"],
        "monolithic": {**mono, "compare": {f"{cushion}.p": "p", f"{cushion}.V": "V"}},
    }
