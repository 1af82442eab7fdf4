"""The seed paper's three experiments through the FMUs, in one place, with one summary table.

1. Fig. 4-5 (LiftedMembrane): the flat film lifted at its centre, with artificial prestress 10
   and 200 N/m2. The paper: the prestress "influences only the iteration path (Fig. 5a,b) while
   reaching the equilibrium". We run both through the FMU with the logSolver category on, record
   every Newton iteration's residual from the FMU's log, plot both iteration histories side by
   side (build/plots/seed_fig5_iterations.png: relative residual against the iteration count,
   one panel per prestress, like the paper's Fig. 5a/5b) and compare the equilibria (lift,
   reaction, cable tension) row by row.
2. Fig. 6 (SlidingCable): the cable through nodes 7, 8, 9 loaded in ten rows to P = 200 N,
   p = 20 N, frictionless, with mu = 0.1, 0.15, 0.2 and with mu = 0.3. The paper: frictionless
   "the nodes 7 and 9 converge to the node 8"; with friction a distinct equilibrium with
   contact forces. We plot the nodes' paths over the load rows (build/plots/seed_fig6_paths.png
   for mu 0 and 0.3, build/plots/seed_fig6_friction_paths.png for mu 0.1-0.2: the points stick,
   then slide onto node 8 in one row) and report |x7 - x8|, |x9 - x8|, the tensions, the
   contact forces, the row where 7 and 9 meet 8 and the iterations per row.
3. Table 1 (Fig. 1): both readings (SleeveCable, SleeveDrawstring) from
   build/table1_readings.json, written by harness/sleeve_readings.py (the main job runs it
   first); RMS per column, the sign of A_dy, the S-shape.

Prints one summary table (experiment, what the paper reports, what we get, verdict) and writes
it with the numbers to build/seed_experiments.json.

    .venv/bin/python harness/seed_experiments.py
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import sys

import numpy as np

import fmi_support as fs
import velarium_run as vr

PLOTS = vr.ROOT / "build" / "plots"
OUT = vr.ROOT / "build" / "seed_experiments.json"
TABLE1 = vr.ROOT / "build" / "table1_readings.json"
ROWS = 10
ITERATION = re.compile(r"iteration (\d+): \|R\| = ([0-9.eE+-]+) \(scale ([0-9.eE+-]+)\)")
CONVERGED = re.compile(r"converged: \|R\| = ([0-9.eE+-]+) \(scale ([0-9.eE+-]+)\)")


def run_rows(name: str, parameters: dict, rows: list[dict], outputs: list[str], log: bool = False):
    """Drive the packed FMU `name` through `rows` (input values per DoStep) with the low-level
    fmpy API: one DoStep per row, outputs read after each (the equilibrium under that row's
    inputs). With `log`, the logSolver messages of each step are kept. Returns (outputs per
    row, relative residuals per step, statuses)."""
    fmu = vr.FMU_DIR / f"{name}.fmu"
    if not fmu.is_file():
        sys.exit(f"{fmu} is missing: run bash harness/main.sh (or velarium pack)")
    md = fs.fmpy.read_model_description(str(fmu))
    unzip = fs.extracted(fmu, vr.ROOT / "build" / "unzipped")
    values, histories, statuses = [], [], []
    refs = {o: fs.vref(md, o) for o in outputs}
    integer = {v.name for v in md.modelVariables if v.type == "Integer"}
    # The recording logger prints every FMU message; the histories are read from the record.
    with contextlib.redirect_stdout(io.StringIO()), fs.slave(unzip, md, name="seed", logging_on=log) as s:
        if log:
            s.setDebugLogging(True, ["logSolver"])
        fs.initialize(s, md, values=parameters)
        t0, t1 = vr.experiment(md)
        h = (t1 - t0) / len(rows)
        for k, row in enumerate(rows):
            for var, value in row.items():
                s.setReal([fs.vref(md, var)], [value])
            fs.clear_log()
            status = fs.status_of(s.doStep, t0 + k * h, h)
            statuses.append(status)
            history = []
            for message in fs.messages():
                m = ITERATION.search(message)
                if m:
                    history.append(float(m.group(2)) / float(m.group(3)))
                m = CONVERGED.search(message)
                if m:
                    history.append(float(m.group(1)) / float(m.group(2)))
            histories.append(history)
            if status != fs.OK:
                break
            values.append({o: float((s.getInteger if o in integer else s.getReal)([r])[0]) for o, r in refs.items()})
    return values, histories, statuses


def lifted_membrane() -> dict:
    rows = [{"lift_force": 50.0 * (k + 1) / ROWS} for k in range(ROWS)]
    outs = ["lift", "reaction_z", "cable_tension", "newton_iterations"]
    runs = {}
    for prestress in (10.0, 200.0):
        values, histories, statuses = run_rows("LiftedMembrane", {"artificial_prestress": prestress}, rows, outs, log=True)
        runs[prestress] = {"values": values, "histories": histories, "statuses": statuses}
    a, b = runs[10.0]["values"], runs[200.0]["values"]
    n = min(len(a), len(b))
    worst = max((abs(a[k][o] - b[k][o]) / max(abs(b[k][o]), 1e-300) for k in range(n) for o in ("lift", "reaction_z", "cable_tension")), default=float("nan"))
    its = {p: [int(v["newton_iterations"]) for v in runs[p]["values"]] for p in runs}
    return {
        "rows": n, "converged_both": n == ROWS, "largest_relative_difference": worst,
        "lift_m": [v["lift"] for v in b], "iterations_per_row": {str(p): its[p] for p in its},
        "residual_histories": {str(p): runs[p]["histories"] for p in runs},
    }


def sliding_cable() -> dict:
    rows = [{"P": 200.0 * (k + 1) / ROWS, "p": 20.0 * (k + 1) / ROWS} for k in range(ROWS)]
    outs = ["x7", "y7", "x8", "y8", "x9", "y9", "T_A7", "T_9B", "contact7", "contact8", "newton_iterations"]
    out = {}
    for mu in (0.0, 0.1, 0.15, 0.2, 0.3):
        values, _, statuses = run_rows("SlidingCable", {"mu": mu}, rows, outs)
        last = values[-1] if values else {}
        its = [int(v["newton_iterations"]) for v in values]
        out[str(mu)] = {
            "rows": len(values), "path": {o: [v[o] for v in values] for o in ("x7", "y7", "x8", "y8", "x9", "y9")},
            "x7_x8_over_span": abs(last.get("x7", np.nan) - last.get("x8", np.nan)) / 4.0,
            "x9_x8_over_span": abs(last.get("x9", np.nan) - last.get("x8", np.nan)) / 4.0,
            "T_A7": last.get("T_A7"), "T_9B": last.get("T_9B"),
            "contact7": last.get("contact7"), "contact8": last.get("contact8"),
            "iterations_per_row": its, "median_iterations": float(np.median(its)) if its else None,
            # First row where 7 and 9 are within 1e-6 of the span of node 8 (None: never).
            "met_at_row": next((k + 1 for k, v in enumerate(values) if max(abs(v["x7"] - v["x8"]), abs(v["x9"] - v["x8"])) < 4e-6), None),
        }
    return out


def plot(lift: dict, slide: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    PLOTS.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, p, tag in zip(axes, ("10.0", "200.0"), ("a", "b")):
        it = 0
        for k, h in enumerate(lift["residual_histories"][p]):
            x = np.arange(it, it + len(h))
            ax.semilogy(x, np.maximum(h, 1e-18), "o-", ms=3, color=f"C{k % 10}")
            it += len(h)
        ax.set_title(f"Fig. 5{tag}: artificial prestress {float(p):g} N/m²")
        ax.set_xlabel("Newton iteration (all ten load rows in turn)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("|R|∞ / force scale")
    fig.suptitle("LiftedMembrane: the iteration histories differ, the equilibria agree")
    fig.tight_layout()
    fig.savefig(PLOTS / "seed_fig5_iterations.png", dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, mu in zip(axes, ("0.0", "0.3")):
        path = slide[mu]["path"]
        ax.plot([0, 4], [0, 0], "ks", ms=6)
        for node, c in (("7", "C0"), ("8", "C3"), ("9", "C2")):
            xs = [{"7": 1.0, "8": 2.0, "9": 3.0}[node]] + path[f"x{node}"]
            ys = [0.0] + path[f"y{node}"]
            ax.plot(xs, ys, "o-", color=c, ms=3, label=f"node {node}")
        last = [0.0, path["x7"][-1], path["x8"][-1], path["x9"][-1], 4.0] if path["x7"] else []
        lasty = [0.0, path["y7"][-1], path["y8"][-1], path["y9"][-1], 0.0] if path["x7"] else []
        ax.plot(last, lasty, "k-", lw=0.8, label="cable, last row")
        ax.set_title(f"Fig. 6: mu = {mu}")
        ax.set_xlabel("x (m)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("y (m)")
    fig.suptitle("SlidingCable: nodes' paths over ten load rows to P = 200 N, p = 20 N")
    fig.tight_layout()
    fig.savefig(PLOTS / "seed_fig6_paths.png", dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(1, 3, figsize=(15, 4), sharey=True)
    for ax, mu in zip(axes, ("0.1", "0.15", "0.2")):
        path = slide[mu]["path"]
        ax.plot([0, 4], [0, 0], "ks", ms=6)
        for node, c in (("7", "C0"), ("8", "C3"), ("9", "C2")):
            xs = [{"7": 1.0, "8": 2.0, "9": 3.0}[node]] + path[f"x{node}"]
            ys = [0.0] + path[f"y{node}"]
            ax.plot(xs, ys, "o-", color=c, ms=3, label=f"node {node}")
            for k, (x, y) in enumerate(zip(xs[1:], ys[1:])):
                if node != "8":
                    ax.annotate(str(k + 1), (x, y), fontsize=6, color=c, xytext=(2, 2), textcoords="offset points")
        met = slide[mu]["met_at_row"]
        ax.set_title(f"Fig. 6: mu = {mu} (7, 9 meet 8 in row {met}; it./row {slide[mu]['iterations_per_row']})", fontsize=8)
        ax.set_xlabel("x (m)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("y (m)")
    fig.suptitle("SlidingCable with friction 0.1-0.2: stick, then one sliding row onto node 8 (row numbers at the points)")
    fig.tight_layout()
    fig.savefig(PLOTS / "seed_fig6_friction_paths.png", dpi=120)
    plt.close(fig)


def summary(lift: dict, slide: dict, table1: dict | None) -> list[tuple[str, str, str, str]]:
    rows = []
    its10, its200 = lift["iterations_per_row"]["10.0"], lift["iterations_per_row"]["200.0"]
    same = lift["converged_both"] and lift["largest_relative_difference"] < 1e-8
    rows.append((
        "Fig. 4-5 lift, prestress 10 vs 200 N/m2",
        "prestress changes only the iteration path",
        f"equilibria agree to {lift['largest_relative_difference']:.1e} (rel.); iterations {sum(its10)} vs {sum(its200)}",
        "reproduced" if same else "NOT reproduced",
    ))
    f0 = slide["0.0"]
    met = f0["rows"] == ROWS and max(f0["x7_x8_over_span"], f0["x9_x8_over_span"]) < 1e-6
    rows.append((
        "Fig. 6 frictionless",
        "nodes 7 and 9 converge to node 8",
        f"|x7-x8|, |x9-x8| = {f0['x7_x8_over_span']:.1e}, {f0['x9_x8_over_span']:.1e} of the span; median {f0['median_iterations']:g} it./row",
        "reproduced" if met else "NOT reproduced",
    ))
    f3 = slide["0.3"]
    distinct = f3["rows"] == ROWS and f3["x7_x8_over_span"] > 0.1 and f3["x9_x8_over_span"] > 0.1
    rows.append((
        "Fig. 6 with friction (mu 0.3)",
        "a distinct equilibrium with contact forces",
        f"7, 8, 9 at x = {f3['path']['x7'][-1]:.3f}, {f3['path']['x8'][-1]:.3f}, {f3['path']['x9'][-1]:.3f}; contact forces {f3['contact7']:.1f}, {f3['contact8']:.1f} N",
        "reproduced (qualitative: the paper gives no numbers)" if distinct else "NOT reproduced",
    ))
    fr = {mu: slide[mu] for mu in ("0.1", "0.15", "0.2")}
    rows.append((
        "Fig. 6 with friction (mu 0.1-0.2)",
        "(not in the paper) stick, then slide onto node 8",
        "; ".join(f"mu {mu}: meet in row {f['met_at_row']}, {max(f['iterations_per_row'])} it. in that row, median {f['median_iterations']:g}" for mu, f in fr.items()),
        "converged, points meet" if all(f["rows"] == ROWS and f["met_at_row"] for f in fr.values()) else "NOT converged",
    ))
    if table1 is None:
        rows.append(("Table 1 (Fig. 1)", "A_dx 3, 19, 42, 44 mm ...", "build/table1_readings.json missing: run harness/sleeve_readings.py", "not run"))
    else:
        c = table1["SleeveCable"]
        cols = ", ".join(f"{k} {v:.2f}" for k, v in c["rms_per_column_mm"].items())
        rows.append((
            "Table 1, SleeveCable reading",
            "A_dx 3/19/42/44 mm, A_dy -2/-1/+1/+3 mm (S-shaped A_dx)",
            f"RMS {c['rms_mm']:.2f} mm ({cols}); A_dy changes sign: {c['A_dy_changes_sign']}; S-shape: {c['S_shape']}",
            "trend match, not a reproduction" if c["rms_mm"] > 1.0 else "reproduced",
        ))
        d = table1["SleeveDrawstring"]
        best = d["best"]
        rows.append((
            "Table 1, SleeveDrawstring reading",
            "as above",
            f"converges only to 2P = {best['largest_2P_reached_N']:.2f} N (of 5 N) on the grid",
            "not reached (a gathered corner element collapses near 0.19-0.2 N, also under displacement control)",
        ))
    return rows


def main() -> int:
    lift = lifted_membrane()
    slide = sliding_cable()
    table1 = json.loads(TABLE1.read_text()) if TABLE1.is_file() else None
    plot(lift, slide)
    rows = summary(lift, slide, table1)
    print("\nThe seed paper's experiments through the FMUs")
    widths = [max(len(r[i]) for r in rows + [("experiment", "paper", "ours", "verdict")]) for i in range(4)]
    for r in [("experiment", "paper", "ours", "verdict")] + rows:
        print(" | ".join(c.ljust(w) for c, w in zip(r, widths)))
    f0 = slide["0.0"]
    print(f"Fig. 6 frictionless iterations per row: {f0['iterations_per_row']}; mu 0.3: {slide['0.3']['iterations_per_row']}")
    for mu in ("0.1", "0.15", "0.2"):
        print(f"Fig. 6 mu {mu}: 7 and 9 meet 8 in row {slide[mu]['met_at_row']}; iterations per row {slide[mu]['iterations_per_row']}")
    print(f"Fig. 5 iterations per row, prestress 10: {lift['iterations_per_row']['10.0']}; 200: {lift['iterations_per_row']['200.0']}")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps({"summary": rows, "lift": lift, "sliding": slide}, indent=1))
    print(f"wrote {OUT.relative_to(vr.ROOT)}, build/plots/seed_fig5_iterations.png, build/plots/seed_fig6_paths.png, build/plots/seed_fig6_friction_paths.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
