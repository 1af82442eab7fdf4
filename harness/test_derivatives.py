"""Directional and adjoint derivatives through fmpy, on every shipped scene: FMI 2's
``fmi2GetDirectionalDerivative`` and FMI 3's ``fmi3GetDirectionalDerivative`` /
``fmi3GetAdjointDerivative`` (``providesDirectionalDerivative(s)``, ``providesAdjointDerivatives``).

Operating point: the inputs ramped half way from their start to their ramp target
(``velarium_run.ramp_target``) in four steps. Checks:

- FMI 2 and FMI 3 give the same numbers bit for bit (the same engine, the same state);
- the adjoint with a seed w equals J w of the directional derivatives, relative to |J| |w|:
  1e-10 (two different solves of an ill-conditioned tangent: measured up to 7.6e-12);
- J equals a second-order one-sided difference of the FMU's own equilibria (FMU state saved,
  inputs moved by δ and 2δ, one DoStep each, state restored; each input alone, or with friction
  along the ramp only), on the scene packed with a residual tolerance of 1e-12 so that the
  difference measures the derivative: 1e-5 of the largest derivative among the outputs of the
  same unit (1e-4 on scenes with wrinkling on: the wrinkled tangent's ε·D0), δ = 1e-5 of the
  ramp (1e-3 with friction), as tests/fmi/derivatives.rs does for the engine. Measured worst per
  scene: printed (``-s``).
"""

from __future__ import annotations

import json
import subprocess

from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi2 import FMU2Slave

import fmi3_support as f3
import velarium_run as vr

TOLERANCE = 1e-5
WRINKLED_TOLERANCE = 1e-4
ADJOINT_TOLERANCE = 1e-10


def operating_point(md) -> dict[str, tuple[float, float]]:
    """Per input: (start, half-way value)."""
    out = {}
    for v in vr.inputs(md):
        start = float(v.start)
        out[v.name] = (start, start + 0.5 * (vr.ramp_target(v) - start))
    return out


def ramp(s, md, setter) -> float:
    """Ramp the inputs to the operating point in four steps; returns the time reached."""
    refs = {v.name: v.valueReference for v in md.modelVariables}
    points = operating_point(md)
    t, h = 0.0, 0.25
    for k in range(1, 5):
        names = list(points)
        setter([refs[n] for n in names], [a + (b - a) * k / 4 for a, b in points.values()])
        s.doStep(t, h)
        t += h
    return t


def real_outputs(md) -> list:
    return [v for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")
            and "fraction" not in v.name and v.name != "contact_gap"]


@pytest.fixture
def tight(model, scene, velarium, tmp_path) -> tuple[Path, Path]:
    """The scene packed with its equilibria solved to a residual tolerance of 1e-12 (FMI 2 and
    FMI 3 archives): differences of equilibria over a small step then measure the derivative,
    not the solver's tolerance."""
    if vr.is_dynamic(model):
        pytest.skip("a scene with time integration: its derivatives are those of a step, not of an equilibrium; "
                    "tests/fmi/dynamic_derivatives.rs and harness/test_coupling_dynamic.py check them against "
                    "differences of the step")
    text = json.loads(scene.read_text())
    text.get("experiment", {}).pop("loads", None)  # no reference run under the load history
    text.setdefault("solver", {})["tolerance"] = 1e-12
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(text))
    run = subprocess.run([str(velarium), "pack", str(path), "--out", str(tmp_path)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    name = text["name"]
    return tmp_path / f"{name}.fmu", tmp_path / f"{name}_fmi3.fmu"


def fmi2_jacobian(fmu: Path) -> np.ndarray:
    md = fmpy.read_model_description(str(fmu))
    unzipdir = fmpy.extract(str(fmu))
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="d")
    try:
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        ramp(s, md, s.setReal)
        outs = [v.valueReference for v in real_outputs(md)]
        return np.array([s.getDirectionalDerivative(outs, [v.valueReference], [1.0]) for v in vr.inputs(md)])
    finally:
        s.freeInstance()


def test_derivatives_match_differences_of_the_fmus_equilibria(tight):
    fmu, fmu3 = tight
    md = fmpy.read_model_description(str(fmu3))
    f3.skip_arrays(md, "tests/fmi/derivatives.rs (ZonedCushion against differences of equilibria)")
    unzipdir = Path(fmpy.extract(str(fmu3)))
    inputs, outputs = vr.inputs(md), real_outputs(md)
    in_refs, out_refs = [v.valueReference for v in inputs], [v.valueReference for v in outputs]
    points = operating_point(md)
    direction = np.array([b - a for a, b in points.values()])
    scene = json.loads(vr.fmu_member(fmu3, "resources/scene.json"))
    friction = any((c.get("sleeve") or {}).get("mu", 0) > 0 for c in scene.get("cables", []))
    with f3.slave(unzipdir, md) as s:
        s.enterInitializationMode(startTime=0.0)
        s.exitInitializationMode()
        t = ramp(s, md, s.setFloat64)
        jacobian = np.array([s.getDirectionalDerivative(out_refs, [r], [1.0]) for r in in_refs])
        # Adjoint = transpose.
        w = np.linspace(-1.0, 1.0, len(out_refs)) + 0.1
        adjoint = np.array(s.getAdjointDerivative(out_refs, in_refs, list(w), nSensitivity=len(in_refs)))
        expected = jacobian @ w
        size = np.abs(jacobian) @ np.abs(w)
        adjoint_error = float(np.max(np.abs(adjoint - expected) / np.maximum(size, 1e-300)))
        assert adjoint_error <= ADJOINT_TOLERANCE, (adjoint, expected)
        # Differences of equilibria, per input (with friction: along the ramp only).
        def inward(v) -> float:
            """The input's range, towards the inside of [min, max] (for an input already at its
            operating value: AnnulusTorsion's displacements start at their max)."""
            lo, hi = float(v.min) if v.min is not None else 0.0, float(v.max) if v.max is not None else 1.0
            size = hi - lo if hi > lo else 1.0
            return -size if float(v.start) + 0.1 * size > hi else size

        seeds = [direction] if friction else [np.eye(len(inputs))[i] * (d if d != 0 else inward(inputs[i]))
                                              for i, d in enumerate(direction)]
        state = s.getFMUState()
        base_inputs = np.array(s.getFloat64(in_refs))
        base = np.array(s.getFloat64(out_refs))

        def at(step):
            s.setFMUState(state)
            s.setFloat64(in_refs, list(base_inputs + step))
            s.doStep(t, 0.25)
            return np.array(s.getFloat64(out_refs))

        worst = 0.0
        units = [v.unit for v in outputs]
        delta = 1e-3 if friction else 1e-5
        for seed in seeds:
            analytic = seed @ jacobian
            f1, f2 = at(delta * seed), at(2 * delta * seed)
            difference = (-3 * base + 4 * f1 - f2) / (2 * delta)
            largest = float(np.max(np.abs(difference)))
            for k, unit in enumerate(units):
                # An output that does not move (0 by symmetry: AnnulusTorsion's hub force
                # resultant, analytic 4e-14 N) is compared at the noise of the differences: the
                # equilibria are solved to a residual, not exactly, so such an output's difference
                # is that noise over the step, measured up to 4.1e-6 of the largest derivative of
                # any output (the hub force under the hub's radial seed, with the solver's
                # locality ordering of the equations; below 1e-6 with the scene's own order). Bound 1e-5.
                if abs(analytic[k]) <= 1e-9 * largest and abs(difference[k]) <= 1e-5 * largest:
                    continue
                scale = max(abs(difference[j]) for j, u in enumerate(units) if u == unit)
                err = abs(analytic[k] - difference[k]) / scale if scale > 0 else abs(analytic[k])
                worst = max(worst, err)
        s.setFMUState(state)
        s.freeFMUState(state)
    print(f"{md.modelName}: worst {worst:.2e} over {len(outputs)} outputs x {len(seeds)} seeds, "
          f"adjoint {adjoint_error:.1e}")
    # A tension field (wrinkling on) puts the tangent-only ε·D0 into J (docs/fmu.md).
    wrinkling = any(m.get("wrinkling", True) for m in scene.get("membranes", []))
    assert worst <= (WRINKLED_TOLERANCE if wrinkling else TOLERANCE)
    # FMI 2: the same numbers.
    assert np.array_equal(fmi2_jacobian(fmu), jacobian)
