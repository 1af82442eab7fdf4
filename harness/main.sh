#!/usr/bin/env bash
# The main job on a fresh machine: build, install the Python environment, pack every shipped
# scene into build/fmus/, calibrate SleeveCable to the seed paper's Table 1 through the FMU, print
# the Table 1 comparison and write build/plots/SleeveCable_*.png (`--model NAME` runs another
# shipped scene's load ramp instead); then shear the pretensioned WrinkledShear film through
# fmpy and plot its wrinkle states (harness/wrinkled_shear.py). Extra arguments go to
# harness/run_main.py.
set -euo pipefail
cd "$(dirname "$0")/.."
bash harness/setup.sh
.venv/bin/python harness/run_main.py "$@"
.venv/bin/python harness/wrinkled_shear.py
