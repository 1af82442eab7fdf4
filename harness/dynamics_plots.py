"""The main job's dynamics (docs/dynamics.md, "Shipped scenes"): run the packed
VibratingMembrane and GustSail FMUs through fmpy with the input histories they carry
(extra/org.fmi-standard.fmi-ls-ref/<Name>_in.csv) and their default experiments, and write

  build/plots/VibratingMembrane.png  the centre's deflection and velocity; kinetic, strain
                                     (less its value at rest) and total energy
  build/plots/GustSail.png           wind pressure, the centre's deflection and velocity,
                                     kinetic energy

Run after harness/run_main.py has packed build/fmus/ (harness/main.sh does both).
"""

from __future__ import annotations

import io
import sys
import zipfile
from pathlib import Path

import fmpy
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import velarium_run as vr  # noqa: E402

PLOTS = vr.ROOT / "build" / "plots"


def run(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The FMU's default experiment under its own input history: (inputs, results)."""
    fmu = vr.FMU_DIR / f"{name}.fmu"
    if not fmu.is_file():
        sys.exit(f"{fmu} is missing: run harness/run_main.py (it packs build/fmus/) first")
    with zipfile.ZipFile(fmu) as z:
        text = z.read(f"extra/org.fmi-standard.fmi-ls-ref/{name}_in.csv").decode()
    inputs = np.genfromtxt(io.StringIO(text), delimiter=",", names=True)
    md = fmpy.read_model_description(str(fmu))
    rows = vr.simulate(fmu, None, input=inputs, output_interval=float(md.defaultExperiment.stepSize))
    return inputs, rows


def vibrating_membrane() -> Path:
    _, r = run("VibratingMembrane")
    t = r["time"]
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    ax[0].plot(t, 1e3 * r["w_center"])
    ax[0].set_ylabel("centre deflection (mm)")
    ax[1].plot(t, r["v_center"])
    ax[1].set_ylabel("centre velocity (m/s)")
    strain = r["strain_energy"] - np.min(r["strain_energy"])
    ax[2].plot(t, 1e3 * r["kinetic_energy"], label="kinetic")
    ax[2].plot(t, 1e3 * strain, label="strain (less its least value)")
    ax[2].plot(t, 1e3 * (r["kinetic_energy"] + strain), label="sum")
    ax[2].set_ylabel("energy (mJ)")
    ax[2].set_xlabel("time (s)")
    ax[2].legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3, frameon=False)
    f1 = float(r["f1"][1:][np.argmin(np.abs(r["w_center"][1:]))])
    fig.suptitle(f"VibratingMembrane: released from 10 Pa, undamped (rho_inf = 1); f1 = {f1:.2f} Hz near flat")
    fig.tight_layout()
    out = PLOTS / "VibratingMembrane.png"
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def gust_sail() -> Path:
    inputs, r = run("GustSail")
    t = r["time"]
    fig, ax = plt.subplots(4, 1, figsize=(8, 10), sharex=True)
    ax[0].plot(inputs["time"], inputs["wind"], drawstyle="default")
    ax[0].set_ylabel("wind pressure (Pa)")
    ax[1].plot(t, 1e3 * r["center_uz"])
    ax[1].set_ylabel("centre deflection (mm)")
    ax[2].plot(t, r["center_vz"])
    ax[2].set_ylabel("centre velocity (m/s)")
    ax[3].plot(t, r["kinetic_energy"])
    ax[3].set_ylabel("kinetic energy (J)")
    ax[3].set_xlabel("time (s)")
    fig.suptitle("GustSail: the form-found four-point sail in a 300 Pa gust (rho_inf = 0.9, 5 % Rayleigh damping)")
    fig.tight_layout()
    out = PLOTS / "GustSail.png"
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def main() -> None:
    PLOTS.mkdir(parents=True, exist_ok=True)
    for made in (vibrating_membrane(), gust_sail()):
        print(f"wrote {made.relative_to(vr.ROOT)}")


if __name__ == "__main__":
    main()
