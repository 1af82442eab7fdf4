"""Plot a membrane coloured by wrinkle state (taut / wrinkled / slack) with tension directions.

Input: the per-element CSV of ``velarium solve SCENE --loads L.csv --elements E.csv``.
Output: a PNG, the deformed triangles seen from +z (x-y projection), coloured by state, with a
short line along the tension direction of every wrinkled triangle.

    .venv/bin/python harness/plot_elements.py E.csv --out build/plots/elements.png [--time T]

Examples:
  .venv/bin/python harness/plot_elements.py build/WindSquare-elements.csv --out build/plots/WindSquare_elements.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

COLOURS = {0: "#4c9be8", 1: "#f0a030", 2: "#d0d0d0"}
NAMES = {0: "taut", 1: "wrinkled", 2: "slack"}


def load(path: Path) -> np.ndarray:
    data = np.genfromtxt(path, delimiter=",", names=True)
    if data.size == 0:
        raise SystemExit(f"{path}: no element rows")
    return np.atleast_1d(data)


def plot(rows: np.ndarray, out: Path, title: str) -> None:
    tris = np.stack([np.column_stack([rows[f"x{k}"], rows[f"y{k}"]]) for k in (1, 2, 3)], axis=1)
    states = rows["state"].astype(int)
    fig, ax = plt.subplots(figsize=(9, 5))
    ax.add_collection(PolyCollection(tris, facecolors=[COLOURS[s] for s in states], edgecolors="white", linewidths=0.3))
    a, b = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    size = np.sqrt(np.median(np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])))
    wrinkled = states == 1
    c = np.column_stack([rows["centroid_x"], rows["centroid_y"]])[wrinkled]
    d = np.column_stack([rows["tension_x"], rows["tension_y"]])[wrinkled] * 0.35 * size
    ax.add_collection(LineCollection(np.stack([c - d, c + d], axis=1), colors="black", linewidths=0.8))
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    ax.legend(handles=[Patch(color=COLOURS[k], label=NAMES[k]) for k in NAMES], loc="upper left", bbox_to_anchor=(1.01, 1.0))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120, bbox_inches="tight")
    plt.close(fig)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("elements", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--time", type=float, help="row time to plot (default: the last)")
    args = parser.parse_args(argv)
    data = load(args.elements)
    time = data["time"].max() if args.time is None else args.time
    rows = data[np.isclose(data["time"], time)]
    if rows.size == 0:
        raise SystemExit(f"{args.elements}: no rows at time {time}")
    counts = {NAMES[k]: int(np.sum(rows["state"] == k)) for k in NAMES}
    plot(rows, args.out, f"t = {time:g}: " + ", ".join(f"{n} {c}" for n, c in counts.items()))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
