#!/usr/bin/env bash
# The main job on a fresh machine: build, install the Python environment, pack every shipped
# scene into build/fmus/, calibrate SleeveCable to the seed paper's Table 1 through the FMU, print
# the Table 1 comparison and write build/plots/SleeveCable_*.png, then both readings of Fig. 1 side
# by side (harness/sleeve_readings.py, build/plots/Table1_readings.png), then the seed paper's three
# experiments in one summary table (harness/seed_experiments.py: Fig. 4-5 iteration histories,
# Fig. 6 node paths, Table 1 per reading; build/plots/seed_fig5_iterations.png,
# seed_fig6_paths.png) (`--model NAME` runs another
# shipped scene's load ramp instead); then shear the pretensioned WrinkledShear film through
# fmpy and plot its wrinkle states (harness/wrinkled_shear.py); finally run the shipped
# LiftedMembrane through fmpy with its ParaView series and 3-D plot (build/runs/LiftedMembrane/)
# and render the series headless with pyvista (build/plots/LiftedMembrane_pyvista.png), and
# the form-found FourPointSail under its wind ramp (build/runs/FourPointSail/; the FMU
# form-finds the sail at instantiation), then the two dynamic FMUs in time
# (harness/dynamics_plots.py: build/plots/VibratingMembrane.png, GustSail.png). Last, speed against error (harness/speed_error.py):
# the error against the closed form over wall time, Hencky disc and wrinkled Lamé annulus at
# growing meshes, with the optional peer (Kratos in /tmp/kratos-venv) beside ours when it is
# installed (build/plots/speed_error.png and .csv). Then the cushion-and-blower system with the
# cushion's mass through every coupling method (harness/coupling_dynamic_study.py, about 2 min:
# build/plots/coupling_dynamic.png, the loop gain against the macro step and the strong run
# beside the monolithic answer).
# Extra arguments go to harness/run_main.py.
set -euo pipefail
cd "$(dirname "$0")/.."
bash harness/setup.sh
.venv/bin/python harness/run_main.py "$@"
.venv/bin/python harness/sleeve_readings.py
.venv/bin/python harness/seed_experiments.py
.venv/bin/python harness/wrinkled_shear.py
.venv/bin/python harness/run_main.py --model LiftedMembrane
.venv/bin/python harness/screenshot.py build/runs/LiftedMembrane/vtk/LiftedMembrane.pvd build/plots/LiftedMembrane_pyvista.png
.venv/bin/python harness/run_main.py --model FourPointSail
.venv/bin/python harness/dynamics_plots.py
.venv/bin/python harness/speed_error.py
.venv/bin/python harness/coupling_dynamic_study.py
