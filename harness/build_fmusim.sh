#!/usr/bin/env bash
# Builds the Reference FMUs' `fmusim` (release v0.0.39, the last one that holds it) for
# harness/test_fmusim.py:   bash harness/build_fmusim.sh REFERENCE_FMUS_CHECKOUT [OUT_DIR]
# then run   FMUSIM=OUT_DIR/fmusim .venv/bin/python -m pytest harness/test_fmusim.py
# REFERENCE_FMUS_CHECKOUT is a git clone of https://github.com/modelica/Reference-FMUs.
# Needs gcc and the -dev packages of zlib, libxml2 and minizip (Debian: zlib1g-dev libxml2-dev
# libminizip-dev). fmusim's CVode solver (SUNDIALS) serves Model Exchange only; every Velarium
# archive is Co-Simulation, so it is replaced by a stub that returns errors (docs/fmu.md, fmusim).
set -euo pipefail
src=${1:?usage: bash harness/build_fmusim.sh REFERENCE_FMUS_CHECKOUT [OUT_DIR]}
out=$(realpath -m "${2:-build/fmusim}")
mkdir -p "$out/src"
git -C "$src" archive v0.0.39 fmusim include src | tar -x -C "$out/src"
cd "$out/src/fmusim"
cat > FMICVodeStub.c <<'STUB'
/* Stands in for FMICVode.c (SUNDIALS): Model Exchange only, never used by Co-Simulation. */
#include <stddef.h>
#include "FMICVode.h"
FMISolver* FMICVodeCreate(const FMISolverParameters* p) { (void)p; return NULL; }
void FMICVodeFree(FMISolver* s) { (void)s; }
FMISolverStatus FMICVodeStep(FMISolver* s, double t, double* r, bool* e) { (void)s; (void)t; (void)r; (void)e; return FMISolverError; }
FMISolverStatus FMICVodeReset(FMISolver* s, double t) { (void)s; (void)t; return FMISolverError; }
STUB
gcc -O1 -w -o "$out/fmusim" -I. -I../include -I/usr/include/minizip -I/usr/include/libxml2 \
    -DFMUSIM_VERSION='"0.0.39"' \
    ../src/FMI.c ../src/FMI1.c ../src/FMI2.c ../src/FMI3.c \
    ../src/structured_variable_name.yy.c ../src/structured_variable_name.tab.c \
    csv.c FMIUtil.c FMIEuler.c FMICVodeStub.c FMIModelDescription.c FMIRecorder.c FMIZip.c \
    FMISimulation.c FMIStaticInput.c FMI1CSSimulation.c FMI1MESimulation.c FMI2CSSimulation.c \
    FMI2MESimulation.c FMI3CSSimulation.c FMI3MESimulation.c fmusim.c miniunzip.c \
    -lminizip -lxml2 -lz -ldl -lm
echo "built $out/fmusim: FMUSIM=$out/fmusim .venv/bin/python -m pytest harness/test_fmusim.py"
