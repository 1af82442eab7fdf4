"""The optional peer of harness/speed_error.py: Kratos Multiphysics (StructuralMechanicsApplication,
MembraneElement3D3N) on our meshes. It runs in the peer's own environment, never the harness's:

    python3 -m venv /tmp/kratos-venv && /tmp/kratos-venv/bin/pip install KratosMultiphysics-all
    /tmp/kratos-venv/bin/python harness/peer_kratos.py hencky MESH.npz
    /tmp/kratos-venv/bin/python harness/peer_kratos.py lame MESH.npz

MESH.npz holds `points` (n x 3, m) and `triangles` (counter-clockwise from +z), exported by
speed_error.py from `velarium solve --vtk` of the same generated scene, so both codes solve the
identical mesh. The problem data are speed_error.py's (imported from it). Prints one JSON line:
{"value": the measured displacement (m), "dof": free unknowns, "seconds": wall time from the
model's construction to the answer (the Python interpreter's start and Kratos' import, about a
second, are left out: in the peer's favour), "iterations": Newton iterations in all}.

- hencky: the clamped disc, follower pressure (SurfaceLoadCondition3D3N, current normal) to
  q = 40 Pa. A flat membrane has no out-of-plane stiffness, and the peer's membrane takes a
  prestress (PRESTRESS_VECTOR, Pa) for it: 10 load steps with 1e5 Pa isotropic prestress (about
  5 % of the final stress), then the prestress brought down 1e4, 1e3, 0 at full load, so the
  answer is the stress-free disc's, the same problem as ours.
- lame: the wrinkled annulus, WrinklingLinear2DLaw over LinearElasticPlaneStress2DLaw, radial
  edge loads as our `radial_edge_load` makes them (half of each rim segment's length to each
  end node, along the node's radial direction; PointLoadCondition3D1N), every node held in z, node (a, 0) in y and (0, a) in x, one
  load step; the measured value is u_x at (a, 0).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import speed_error as se  # noqa: E402  (the problem data; speed_error imports nothing Kratos lacks)


def build(points, triangles, thickness, e, nu, wrinkling: bool):
    import KratosMultiphysics as KM
    import KratosMultiphysics.StructuralMechanicsApplication as SMA  # noqa: F401

    model = KM.Model()
    mp = model.CreateModelPart("membrane")
    mp.ProcessInfo[KM.DOMAIN_SIZE] = 3
    for var in (KM.DISPLACEMENT, KM.REACTION, KM.POSITIVE_FACE_PRESSURE, KM.NEGATIVE_FACE_PRESSURE):
        mp.AddNodalSolutionStepVariable(var)
    mp.AddNodalSolutionStepVariable(SMA.POINT_LOAD)
    for i, (x, y, z) in enumerate(points):
        mp.CreateNewNode(i + 1, float(x), float(y), float(z))
    prop = mp.GetProperties()[1]
    prop.SetValue(KM.THICKNESS, thickness)
    prop.SetValue(KM.YOUNG_MODULUS, e)
    prop.SetValue(KM.POISSON_RATIO, nu)
    prop.SetValue(KM.DENSITY, 1.0)
    if wrinkling:
        sub = KM.Properties(2)
        sub.SetValue(KM.THICKNESS, thickness)
        sub.SetValue(KM.YOUNG_MODULUS, e)
        sub.SetValue(KM.POISSON_RATIO, nu)
        sub.SetValue(KM.CONSTITUTIVE_LAW, SMA.LinearElasticPlaneStress2DLaw())
        prop.AddSubProperties(sub)
        import KratosMultiphysics.ConstitutiveLawsApplication as CLA

        prop.SetValue(KM.CONSTITUTIVE_LAW, CLA.WrinklingLinear2DLaw())
    else:
        prop.SetValue(KM.CONSTITUTIVE_LAW, SMA.LinearElasticPlaneStress2DLaw())
    prop.SetValue(SMA.PRESTRESS_VECTOR, KM.Vector([0.0, 0.0, 0.0]))
    for k, (a, b, c) in enumerate(triangles):
        mp.CreateNewElement("MembraneElement3D3N", k + 1, [int(a) + 1, int(b) + 1, int(c) + 1], prop)
    KM.VariableUtils().AddDof(KM.DISPLACEMENT_X, KM.REACTION_X, mp)
    KM.VariableUtils().AddDof(KM.DISPLACEMENT_Y, KM.REACTION_Y, mp)
    KM.VariableUtils().AddDof(KM.DISPLACEMENT_Z, KM.REACTION_Z, mp)
    return model, mp, prop


def strategy(mp):
    import KratosMultiphysics as KM
    import KratosMultiphysics.LinearSolversApplication  # noqa: F401  (registers sparse_lu, Eigen's SparseLU)
    from KratosMultiphysics import python_linear_solver_factory

    linear = python_linear_solver_factory.ConstructSolver(KM.Parameters('{"solver_type": "sparse_lu"}'))
    scheme = KM.ResidualBasedIncrementalUpdateStaticScheme()
    criterion = KM.ResidualCriteria(1e-8, 1e-12)
    criterion.SetEchoLevel(0)
    bns = KM.ResidualBasedBlockBuilderAndSolver(linear)
    s = KM.ResidualBasedNewtonRaphsonStrategy(mp, scheme, criterion, bns, 100, False, False, True)
    s.SetEchoLevel(0)
    s.Initialize()
    return s


def solve_step(s, mp, step: int) -> int:
    """One load step; its Newton iterations. A step that does not converge is an error."""
    import KratosMultiphysics as KM

    mp.CloneTimeStep(float(step))
    mp.ProcessInfo[KM.STEP] = step
    s.InitializeSolutionStep()
    s.Predict()
    converged = s.SolveSolutionStep()
    s.FinalizeSolutionStep()
    if not converged:
        raise RuntimeError(f"the peer's step {step} did not converge")
    return mp.ProcessInfo[KM.NL_ITERATION_NUMBER]


def hencky(points, triangles) -> dict:
    import KratosMultiphysics as KM
    import KratosMultiphysics.StructuralMechanicsApplication as SMA

    started = time.perf_counter()
    _model, mp, prop = build(points, triangles, se.HENCKY_H, se.HENCKY_E, se.HENCKY_NU, wrinkling=False)
    r = np.hypot(points[:, 0], points[:, 1])
    rim = np.flatnonzero(r > se.HENCKY_A * (1 - 1e-9))
    centre = int(np.argmin(r))
    for i in rim:
        node = mp.Nodes[int(i) + 1]
        for d in (KM.DISPLACEMENT_X, KM.DISPLACEMENT_Y, KM.DISPLACEMENT_Z):
            node.Fix(d)
    for k, (a, b, c) in enumerate(triangles):
        mp.CreateNewCondition("SurfaceLoadCondition3D3N", k + 1, [int(a) + 1, int(b) + 1, int(c) + 1], prop)
    s = strategy(mp)
    iterations, step = 0, 0
    for prestress, q in [(1e5, se.HENCKY_Q * f) for f in np.linspace(0.1, 1, 10)] + [(1e4, se.HENCKY_Q), (1e3, se.HENCKY_Q), (0.0, se.HENCKY_Q)]:
        prop.SetValue(SMA.PRESTRESS_VECTOR, KM.Vector([prestress, prestress, 0.0]))
        for node in mp.Nodes:
            node.SetSolutionStepValue(KM.POSITIVE_FACE_PRESSURE, 0, q)
        step += 1
        iterations += solve_step(s, mp, step)
        w = mp.Nodes[centre + 1].GetSolutionStepValue(KM.DISPLACEMENT_Z)
    seconds = time.perf_counter() - started
    dof = 3 * (len(points) - len(rim))
    return {"value": abs(w), "dof": dof, "seconds": seconds, "iterations": int(iterations)}


def lame(points, triangles) -> dict:
    import KratosMultiphysics as KM
    import KratosMultiphysics.StructuralMechanicsApplication as SMA

    started = time.perf_counter()
    _model, mp, prop = build(points, triangles, se.LAME_T, se.LAME_E, se.LAME_NU, wrinkling=True)
    r = np.hypot(points[:, 0], points[:, 1])
    for node in mp.Nodes:
        node.Fix(KM.DISPLACEMENT_Z)
    east = int(np.argmin(np.hypot(points[:, 0] - se.LAME_A, points[:, 1])))
    north = int(np.argmin(np.hypot(points[:, 0], points[:, 1] - se.LAME_A)))
    mp.Nodes[east + 1].Fix(KM.DISPLACEMENT_Y)
    mp.Nodes[north + 1].Fix(KM.DISPLACEMENT_X)
    n_out = se.LAME_SIGMA_OUT * se.LAME_T
    force = np.zeros_like(points)
    for radius, per_length in ((se.LAME_A, -se.LAME_TAU * n_out), (se.LAME_B, n_out)):
        ring = np.flatnonzero(np.abs(r - radius) < 1e-9 * radius)
        ring = ring[np.argsort(np.arctan2(points[ring, 1], points[ring, 0]))]
        for i, j in zip(ring, np.roll(ring, -1)):
            half = 0.5 * np.linalg.norm(points[j] - points[i])
            for k in (i, j):
                force[k] += per_length * half * np.array([points[k, 0], points[k, 1], 0.0]) / r[k]
    loaded = np.flatnonzero(np.abs(force).sum(axis=1) > 0)
    for k, i in enumerate(loaded):
        mp.CreateNewCondition("PointLoadCondition3D1N", k + 1, [int(i) + 1], prop)
        mp.Nodes[int(i) + 1].SetSolutionStepValue(SMA.POINT_LOAD, 0, KM.Vector(list(map(float, force[i]))))
    s = strategy(mp)
    iterations = solve_step(s, mp, 1)
    u = mp.Nodes[east + 1].GetSolutionStepValue(KM.DISPLACEMENT_X)
    seconds = time.perf_counter() - started
    return {"value": u, "dof": 2 * len(points) - 2, "seconds": seconds, "iterations": int(iterations)}


def main(argv: list[str]) -> None:
    if len(argv) != 2 or argv[0] not in ("hencky", "lame"):
        sys.exit("usage: peer_kratos.py hencky|lame MESH.npz")
    data = np.load(argv[1])
    points, triangles = data["points"], data["triangles"]
    result = (hencky if argv[0] == "hencky" else lame)(points, triangles)
    print(json.dumps(result))


if __name__ == "__main__":
    main(sys.argv[1:])
