"""The main job (README, "Set-up"; docs/harness.md; run it through harness/main.sh), and a run
of any scene or FMU (README's tour, "Your own scene"; docs/harness.md, "Running one scene or FMU").

1. Pack every shipped scene (modelDescription/<Name>/scene.json) into build/fmus/<Name>.fmu
   with target/release/velarium.
2. Default (SleeveCable, the seed paper's Table 1): calibrate the rubber's shear modulus and
   the sleeve friction to Table 1 through the FMU (harness/calibrate_sleeve.py), print our
   numbers beside the experiment and write build/plots/SleeveCable_table1.png and
   SleeveCable_deformed.png (harness/sleeve_table.py).
3. With a scene file or an FMU (``run_main.py SCENE.json``), or --model NAME (a shipped
   scene): the package's `python -m velarium.run` (python/velarium/run.py, docs/python.md;
   one implementation) runs it through fmpy, with --loads (a load table; default: every input
   ramped to its max), --scale (the 3-D picture's displacement scale factor) and --cut/--no-cut
   (a cushion cut open), and writes build/runs/<Name>/: <Name>.png (every output against the
   input that varies, or time), <Name>_3d.png (pyvista, off screen: wrinkle state and major
   principal stress in kPa/MPa, the scale factor stated) and the ParaView series vtk/<Name>.pvd.
   Its --help (python -m velarium.run --help) explains the pressure sign on roofs.

Examples:
  .venv/bin/python harness/run_main.py modelDescription/PrestressedCable/scene.json --loads examples/PrestressedCable-loads.csv
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import velarium_run as vr
from velarium.engine import VelariumError
from velarium.fmu import RunEndedEarly
from velarium.run import add_run_options, run_any

RUNS = vr.ROOT / "build" / "runs"


def pack_all(binary: Path) -> list[Path]:
    vr.FMU_DIR.mkdir(parents=True, exist_ok=True)
    fmus = []
    for name in vr.shipped_models():
        scene = vr.SCENES / name / "scene.json"
        run = subprocess.run([str(binary), "pack", str(scene), "--out", str(vr.FMU_DIR), "--fmi", "2"], capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"packing {scene} failed:\n{run.stderr}")
        fmus.append(Path(run.stdout.splitlines()[0]))  # the FMI 2 archive (the FMI 3 one follows)
        print(f"packed {fmus[-1].relative_to(vr.ROOT)}")
    return fmus


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("target", nargs="?", type=Path, help="a scene (.json) or an FMU (.fmu) to run instead of the main job")
    parser.add_argument("--model", default=None, help="a shipped scene to run (default: the SleeveCable main job)")
    parser.add_argument("--out", type=Path, default=None, help="output directory of a run (default: build/runs/<Name>)")
    parser.add_argument("--velarium", type=Path, default=vr.VELARIUM, help="the velarium binary")
    add_run_options(parser)
    args = parser.parse_args(argv)
    if not args.velarium.is_file():
        sys.exit(f"{args.velarium} is missing: run `cargo build --release` (or bash harness/setup.sh)")
    # The package (velarium.run) runs this build, with libvelarium.so beside it.
    os.environ["VELARIUM_HOME"] = str(args.velarium.resolve().parent)
    if args.target is not None:
        if not args.target.is_file():
            sys.exit(f"{args.target}: no such file")
        try:
            run_any(args.target, args.out or RUNS / _name(args.target), vr.FMU_DIR, loads=args.loads, scale=args.scale, cut=args.cut)
        except (ValueError, VelariumError, RunEndedEarly) as e:
            sys.exit(str(e))
        return

    fmus = pack_all(args.velarium)
    model = args.model or "SleeveCable"
    fmu = next((f for f in fmus if f.stem == model), None)
    if fmu is None:
        sys.exit(f"no shipped scene is named {model}: {[f.stem for f in fmus]} (pass a scene file to run your own)")
    if model == "SleeveCable":
        import calibrate_sleeve
        import sleeve_table

        calibrate_sleeve.main()
        sleeve_table.main([])
        return
    run_any(fmu, args.out or RUNS / fmu.stem, vr.FMU_DIR, loads=args.loads, scale=args.scale, cut=args.cut)


def _name(target: Path) -> str:
    """The model name of a scene or FMU (its output directory's name)."""
    if target.suffix == ".fmu":
        import fmpy

        return fmpy.read_model_description(str(target)).modelName
    import json

    return json.loads(target.read_text())["name"]


if __name__ == "__main__":
    main()
