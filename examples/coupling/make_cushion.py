"""Write the two cushion scenes of the coupling example (docs/coupling.md):

- cushion_pressure.json: the cushion driven by its pressure (`p`, a follower pressure on the
  closed group), output its volume `V`: the structural half of the coupled system;
- cushion_gas.json: the same cushion with the gas law inside (`dN`, a `gas` input), outputs
  the pressure `p` and the volume `V`: the monolithic reference's structure.

Both carry a snow load `snow` on the top skin. The cushion: a 2 m x 2 m pillow, top and bottom
skins z = ±0.2 sin(πx/2) sin(πy/2) sharing the rim (held), 6 x 6 cells per skin, a 0.2 mm foil
(E 400 MPa, ν 0.4, wrinkling off: an inflated cushion's skins stay taut).

    python3 examples/coupling/make_cushion.py
"""

import json
import math
from pathlib import Path

HERE = Path(__file__).resolve().parent
L, F, N = 2.0, 0.2, 6


def mesh():
    nodes, top_id, bot_id = [], {}, {}
    for j in range(N + 1):
        for i in range(N + 1):
            x, y = L * i / N, L * j / N
            top_id[i, j] = len(nodes)
            nodes.append([x, y, F * math.sin(math.pi * x / L) * math.sin(math.pi * y / L)])
    for j in range(N + 1):
        for i in range(N + 1):
            if i in (0, N) or j in (0, N):
                bot_id[i, j] = top_id[i, j]
            else:
                x, y = L * i / N, L * j / N
                bot_id[i, j] = len(nodes)
                nodes.append([x, y, -F * math.sin(math.pi * x / L) * math.sin(math.pi * y / L)])
    top, bottom = [], []
    for j in range(N):
        for i in range(N):
            for ids, out in ((top_id, top), (bot_id, bottom)):
                a, b, c, d = ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]
                tris = [[a, b, c], [a, c, d]] if (i + j) % 2 == 0 else [[a, b, d], [b, c, d]]
                out += tris if out is top else [[t[0], t[2], t[1]] for t in tris]
    rim = sorted(top_id[i, j] for i in range(N + 1) for j in range(N + 1) if i in (0, N) or j in (0, N))
    return nodes, top + bottom, len(top), rim


def reference_volume(nodes, triangles) -> float:
    v = 0.0
    for p, q, r in triangles:
        a, b, c = nodes[p], nodes[q], nodes[r]
        v += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
              + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0
    return v


def scene(name: str, drive: dict, outputs: list) -> dict:
    nodes, triangles, ntop, rim = mesh()
    return {
        "format": 1,
        "name": name,
        "description": "A 2 m x 2 m air cushion (two 0.2 mm foil skins, E 400 MPa, nu 0.4, rim held) under its "
                       "inner pressure and a snow load on the top skin: the structure of the cushion-and-blower "
                       "coupling example (docs/coupling.md). Written by examples/coupling/make_cushion.py.",
        "geometry": {
            "nodes": nodes,
            "triangles": triangles,
            "node_sets": {"rim": rim},
            "triangle_sets": {"skins": list(range(len(triangles))), "top": list(range(ntop))},
        },
        "membranes": [{"name": "foil", "triangles": "skins", "thickness": 2e-4,
                       "material": {"kind": "svk", "E": 4e8, "nu": 0.4}, "wrinkling": False}],
        "supports": [{"nodes": "rim", "fix": ["x", "y", "z"]}],
        "inputs": [drive, {"name": "snow", "load": {"kind": "snow", "membrane": "foil", "zone": "top"},
                           "start": 0, "min": 0, "max": 500}],
        "outputs": outputs,
        "solver": {"tolerance": 1e-12},
        "experiment": {"start_time": 0, "stop_time": 1, "step_size": 0.25},
    }


def main():
    volume = {"name": "V", "probe": {"kind": "enclosed_volume", "membrane": "foil"}}
    pressure = scene("CushionPressure",
                     {"name": "p", "load": {"kind": "pressure", "membrane": "foil", "follower": True},
                      "start": 200, "min": 0, "max": 1500},
                     [volume])
    gas = scene("CushionGas",
                {"name": "dN", "load": {"kind": "gas", "membrane": "foil", "atmosphere": 101325.0},
                 "start": 0, "min": -1, "max": 1},
                [{"name": "p", "probe": {"kind": "enclosed_pressure", "input": "dN"}}, volume])
    for s, f in ((pressure, "cushion_pressure.json"), (gas, "cushion_gas.json")):
        (HERE / f).write_text(json.dumps(s, indent=1) + "\n")
    nodes, triangles, _, _ = mesh()
    print("reference volume", reference_volume(nodes, triangles))


if __name__ == "__main__":
    main()
