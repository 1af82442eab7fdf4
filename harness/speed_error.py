"""Speed against error as a picture: the error against the closed form over wall time, for the
Hencky disc and the wrinkled Lamé annulus at growing meshes (docs/harness.md, "Speed against
error"; issue 30 point 6).

    .venv/bin/python harness/speed_error.py [--out build/plots/speed_error.png] [--quick] [--no-peer]

Each point is one `velarium solve` process (scene file to CSV, as a user runs it, one thread)
on a generated mesh; its wall time is the process's, its error the relative error of one
displacement against the closed form:

- Hencky disc (docs/mechanics.md §4a): radius a = 0.5 m, h = 0.1 mm, E = 200 MPa, nu = 0.3,
  clamped rim, follower pressure q = 40 Pa (qa/(Eh) = 1e-3) from the flat start in one row;
  closed form w0/a = 0.065404 (exact kinematics; small-rotation 0.65344 (qa/Eh)^(1/3) =
  0.065344). Error: |w_centre/a - 0.065404| / 0.065404. Meshes: the disc generator, 8-64 rings.
- Wrinkled Lamé annulus (docs/mechanics.md §4b): a = 1 m, b = 4 m, E = 1 MPa, nu = 0.3,
  t = 1 mm, radial edge loads T_out t = 1e-3 N/m outward at b and tau T_out t inward at a,
  tau = 3 (wrinkled out to L/a = 1.80566). The loads are 1000x smaller than
  tests/verification/lame_annulus.rs's so that strains are about 3e-6 and the small-strain
  closed form holds to that order. Closed form of the inner rim's radial displacement:
  Lamé outside L (sigma_theta(L) = 0, sigma_r = A (1 + L^2/r^2), 2 A L = T_in a) gives
  u(L) = -nu 2 A L / E; the tension field inside L (sigma_r = T_in a / r uniaxial, so
  du/dr = sigma_r / E) gives u(a) = u(L) - (T_in a / E) ln(L / a). Error: |u_x(a, 0) - u(a)| /
  |u(a)|. Meshes: the annulus generator, rings x sectors 9x24 to 72x192.

With the optional peer installed (KratosMultiphysics with its StructuralMechanicsApplication in
a separate environment, /tmp/kratos-venv by default or $KRATOS_PYTHON; harness/peer_kratos.py),
the peer solves the identical meshes (the node coordinates and triangles of our generated mesh,
written by `velarium solve --vtk`) and its points are drawn beside ours; without it the plot
shows ours alone and its title says so. The numbers go to build/plots/speed_error.csv too.

Examples:
  .venv/bin/python harness/speed_error.py --quick --no-peer --out build/plots/speed_error_quick.png
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, asdict
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
VELARIUM = ROOT / "target" / "release" / "velarium"
KRATOS_PYTHON = Path(os.environ.get("KRATOS_PYTHON", "/tmp/kratos-venv/bin/python"))

# Hencky disc, docs/mechanics.md §4a.
HENCKY_A, HENCKY_H, HENCKY_E, HENCKY_NU, HENCKY_Q = 0.5, 1e-4, 2e8, 0.3, 40.0
HENCKY_W0_OVER_A = 0.065404  # follower pressure, exact kinematics, qa/(Eh) = 1e-3
# Lamé annulus, docs/mechanics.md §4b.
LAME_A, LAME_B, LAME_E, LAME_NU, LAME_T = 1.0, 4.0, 1e6, 0.3, 1e-3
LAME_SIGMA_OUT, LAME_TAU = 1.0, 3.0  # Pa; T_out t = 1e-3 N/m


@dataclass
class Point:
    case: str      # "hencky" or "lame"
    solver: str    # "velarium" or "kratos"
    mesh: str      # "16 rings" or "18x48"
    dof: int       # free displacement unknowns
    seconds: float  # wall time of the whole process
    value: float   # the measured displacement (m)
    reference: float
    error: float   # relative
    iterations: int = -1  # the peer's Newton iterations in all (ours: not read, -1)


def hencky_reference() -> float:
    return HENCKY_W0_OVER_A * HENCKY_A


def lame_reference(a: float = LAME_A, b: float = LAME_B, e: float = LAME_E, nu: float = LAME_NU,
                   sigma_out: float = LAME_SIGMA_OUT, tau: float = LAME_TAU) -> float:
    """The inner rim's radial displacement (m, negative: inward) of the wrinkled annulus."""
    rho = b / a
    if not 2 * rho**2 / (rho**2 + 1) < tau < rho:
        raise ValueError(f"tau = {tau} is outside the wrinkled range ({2 * rho**2 / (rho**2 + 1)}, {rho})")
    big_l = a * (rho**2 / tau) * (1 - math.sqrt(1 - tau**2 / rho**2))
    t_in = tau * sigma_out
    amp = t_in * a / (2 * big_l)
    u_l = -nu * 2 * amp * big_l / e
    return u_l - (t_in * a / e) * math.log(big_l / a)


def hencky_scene(rings: int) -> dict:
    return {
        "format": 1, "name": f"Hencky{rings}",
        "geometry": {"generators": [{"kind": "disc", "name": "disc", "center": [0, 0, 0], "radius": HENCKY_A, "rings": rings}]},
        "membranes": [{"name": "film", "triangles": "disc", "thickness": HENCKY_H,
                       "material": {"kind": "svk", "E": HENCKY_E, "nu": HENCKY_NU}}],
        "supports": [{"nodes": "disc.rim", "fix": ["x", "y", "z"]}],
        "inputs": [{"name": "q", "load": {"kind": "pressure", "membrane": "film", "follower": True}}],
        "outputs": [{"name": "w", "probe": {"kind": "displacement", "node": "disc.center", "component": "z"}}],
        "solver": {"threads": 1},
    }


def lame_scene(rings: int, sectors: int) -> dict:
    if sectors % 4:
        raise ValueError(f"sectors = {sectors}: a multiple of 4 puts a node on the y axis")
    outer = rings * sectors  # ring k holds nodes k*sectors .. (k+1)*sectors - 1; node 0 at (a, 0)
    return {
        "format": 1, "name": f"Lame{rings}x{sectors}",
        "geometry": {"generators": [{"kind": "annulus", "name": "ring", "center": [0, 0, 0], "inner_radius": LAME_A,
                                     "outer_radius": LAME_B, "rings": rings, "sectors": sectors}],
                     "node_sets": {"east": [0], "north": [sectors // 4], "east_out": [outer]}},
        "membranes": [{"name": "film", "triangles": "ring", "thickness": LAME_T,
                       "material": {"kind": "svk", "E": LAME_E, "nu": LAME_NU}}],
        "supports": [{"nodes": "ring.all", "fix": ["z"]}, {"nodes": "east", "fix": ["y"]}, {"nodes": "north", "fix": ["x"]}],
        "inputs": [{"name": "inner", "load": {"kind": "radial_edge_load", "nodes": "ring.inner_rim", "center": [0, 0, 0], "closed": True}},
                   {"name": "outer", "load": {"kind": "radial_edge_load", "nodes": "ring.outer_rim", "center": [0, 0, 0], "closed": True}}],
        "outputs": [{"name": "u_in", "probe": {"kind": "displacement", "node": "east", "component": "x"}}],
        "solver": {"threads": 1},
    }


def hencky_loads() -> tuple[list[str], list[list[float]]]:
    return ["time", "q"], [[0, 0], [1, HENCKY_Q]]


def lame_loads() -> tuple[list[str], list[list[float]]]:
    n_out = LAME_SIGMA_OUT * LAME_T
    return ["time", "inner", "outer"], [[0, 0, 0], [1, -LAME_TAU * n_out, n_out]]


def hencky_dof(rings: int) -> int:
    return 3 * (1 + 3 * rings * (rings + 1) - 6 * rings)


def lame_dof(rings: int, sectors: int) -> int:
    return 2 * (rings + 1) * sectors - 2


def solve_once(scene: dict, loads: tuple[list[str], list[list[float]]], workdir: Path, binary: Path = VELARIUM,
               vtk: Path | None = None) -> tuple[dict[str, float], float]:
    """Run `velarium solve` on the scene; the last row's outputs and the process's wall time."""
    path = workdir / f"{scene['name']}.json"
    path.write_text(json.dumps(scene))
    table = workdir / f"{scene['name']}-loads.csv"
    header, rows = loads
    table.write_text(",".join(header) + "\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows))
    out = workdir / f"{scene['name']}.csv"
    args = [str(binary), "solve", str(path), "--loads", str(table), "--out", str(out), "--quiet", "--threads", "1"]
    if vtk is not None:
        args += ["--vtk", str(vtk)]
    started = time.perf_counter()
    run = subprocess.run(args, capture_output=True, text=True)
    seconds = time.perf_counter() - started
    if run.returncode != 0:
        raise RuntimeError(f"velarium solve {path.name} failed:\n{run.stderr}")
    with out.open() as f:
        last = list(csv.DictReader(f))[-1]
    return {k: float(v) for k, v in last.items()}, seconds


HENCKY_RINGS = [8, 16, 32, 64]
LAME_MESHES = [(9, 24), (18, 48), (36, 96), (72, 192)]


def ours(workdir: Path, quick: bool = False, binary: Path = VELARIUM) -> list[Point]:
    points = []
    hencky = HENCKY_RINGS[:3] if quick else HENCKY_RINGS
    lame = LAME_MESHES[:3] if quick else LAME_MESHES
    for rings in hencky:
        out, seconds = solve_once(hencky_scene(rings), hencky_loads(), workdir, binary)
        ref = hencky_reference()
        points.append(Point("hencky", "velarium", f"{rings} rings", hencky_dof(rings), seconds, out["w"], ref,
                            abs(out["w"] - ref) / abs(ref)))
    for rings, sectors in lame:
        out, seconds = solve_once(lame_scene(rings, sectors), lame_loads(), workdir, binary)
        ref = lame_reference()
        points.append(Point("lame", "velarium", f"{rings}x{sectors}", lame_dof(rings, sectors), seconds, out["u_in"], ref,
                            abs(out["u_in"] - ref) / abs(ref)))
    return points


def peer_available(python: Path = KRATOS_PYTHON) -> str | None:
    """None when the peer can run, else why not."""
    if not python.is_file():
        return f"{python} is missing (install KratosMultiphysics-all into /tmp/kratos-venv, docs/harness.md)"
    probe = subprocess.run([str(python), "-c", "import KratosMultiphysics.StructuralMechanicsApplication"],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        return f"{python} cannot import KratosMultiphysics.StructuralMechanicsApplication: {probe.stderr.strip().splitlines()[-1:]}"
    return None


def peer(workdir: Path, quick: bool = False, python: Path = KRATOS_PYTHON, binary: Path = VELARIUM) -> list[Point]:
    """The peer on our meshes: each mesh written by `velarium solve --vtk` (its reference points
    and triangles), then harness/peer_kratos.py in the peer's environment."""
    points = []
    cases = [("hencky", r, None) for r in (HENCKY_RINGS[:3] if quick else HENCKY_RINGS)]
    cases += [("lame", r, s) for r, s in (LAME_MESHES[:3] if quick else LAME_MESHES)]
    for case, rings, sectors in cases:
        if case == "hencky":
            scene, loads, ref, label = hencky_scene(rings), hencky_loads(), hencky_reference(), f"{rings} rings"
        else:
            scene, loads, ref, label = lame_scene(rings, sectors), lame_loads(), lame_reference(), f"{rings}x{sectors}"
        vtk = workdir / f"{scene['name']}-vtk"
        solve_once(scene, loads, workdir, binary, vtk=vtk)
        mesh = workdir / f"{scene['name']}-mesh.npz"
        export_mesh(scene, vtk, mesh)
        # One thread, as ours: the peer's OpenMP threads otherwise spin against each other on a
        # shared machine (8 rings: 16.8 s with two threads, 2.0 s with one).
        env = dict(os.environ, OMP_NUM_THREADS="1")
        run = subprocess.run([str(python), str(HERE / "peer_kratos.py"), case, str(mesh)], capture_output=True, text=True, env=env)
        if run.returncode != 0:
            raise RuntimeError(f"peer_kratos.py {case} {label} failed:\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}")
        result = json.loads(next(line for line in reversed(run.stdout.splitlines()) if line.startswith("{")))
        value = result["value"]
        points.append(Point(case, "kratos", label, result["dof"], result["seconds"], value, ref, abs(value - ref) / abs(ref),
                            result["iterations"]))
    return points


def export_mesh(scene: dict, vtk: Path, path: Path) -> None:
    """Our generated mesh (reference points, triangles) and the node sets the peer needs, as .npz."""
    sys.path.insert(0, str(ROOT / "python"))
    from velarium.paraview import read_vtu

    first = sorted(vtk.glob("*.vtu"))[0]
    grid = read_vtu(first)
    tris = grid.connectivity[: 3 * int((grid.types == 5).sum())].reshape(-1, 3)
    np.savez(path, points=grid.points, triangles=tris)


def plot(points: list[Point], path: Path, peer_note: str | None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    titles = {"hencky": "Hencky disc, q a/(E h) = 1e-3: centre deflection\nvs w0/a = 0.065404 (mechanics §4a)",
              "lame": "Wrinkled Lamé annulus, rho = 4, tau = 3: inner rim u_r\nvs tension-field + Lamé closed form (mechanics §4b)"}
    styles = {"velarium": dict(marker="o", color="C0"), "kratos": dict(marker="s", color="C3")}
    for ax, case in zip(axes, ("hencky", "lame")):
        for solver in ("velarium", "kratos"):
            sel = [p for p in points if p.case == case and p.solver == solver]
            if not sel:
                continue
            ax.loglog([p.seconds for p in sel], [p.error for p in sel], "-", label=solver, **styles[solver])
            for p in sel:
                ax.annotate(p.mesh, (p.seconds, p.error), textcoords="offset points", xytext=(4, 4), fontsize=7)
        ax.set_xlabel("wall time [s], one thread (ours: the whole `velarium solve` process;\n"
                      "the peer: from building its model to the answer, its import left out)", fontsize=8)
        ax.set_ylabel("relative error against the closed form [-]")
        ax.set_title(titles[case], fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    if peer_note is None:
        fig.suptitle("Speed against error: Velarium and the peer (Kratos, MembraneElement3D3N) on identical meshes")
    else:
        fig.suptitle(f"Speed against error: Velarium alone (no peer: {peer_note})", fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_csv(points: list[Point], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(asdict(points[0])))
        w.writeheader()
        for p in points:
            w.writerow(asdict(p))


def main(argv: list[str] | None = None) -> list[Point]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=ROOT / "build" / "plots" / "speed_error.png", help="the plot (a .csv of the points beside it)")
    parser.add_argument("--quick", action="store_true", help="the three smallest meshes of each case only")
    parser.add_argument("--no-peer", action="store_true", help="ours alone even when the peer is installed")
    parser.add_argument("--velarium", type=Path, default=VELARIUM, help="the velarium binary")
    args = parser.parse_args(argv)
    if not args.velarium.is_file():
        sys.exit(f"{args.velarium} is missing: run `cargo build --release` (or bash harness/setup.sh)")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        points = ours(work, args.quick, args.velarium)
        note = "--no-peer" if args.no_peer else peer_available()
        if note is None:
            try:
                points += peer(work, args.quick, binary=args.velarium)
            except RuntimeError as e:
                note = "the peer failed, see the log"
                print(e, file=sys.stderr)
    print(f"{'case':7} {'solver':9} {'mesh':12} {'DOF':>7} {'time s':>8} {'value m':>13} {'error':>9} {'iterations':>10}")
    for p in points:
        its = "" if p.iterations < 0 else str(p.iterations)
        print(f"{p.case:7} {p.solver:9} {p.mesh:12} {p.dof:7d} {p.seconds:8.3f} {p.value:13.6e} {p.error:9.2e} {its:>10}")
    title_note = note
    plot(points, args.out, title_note)
    write_csv(points, args.out.with_suffix(".csv"))
    print(f"wrote {args.out} and {args.out.with_suffix('.csv')}" + ("" if note is None else f" (ours alone: {note})"))
    return points


if __name__ == "__main__":
    main()
