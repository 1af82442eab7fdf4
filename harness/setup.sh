#!/usr/bin/env bash
# Build the release binary and library, and install the harness's Python environment in .venv
# (fmpy, fmutool, pytest, numpy, scipy, matplotlib, meshio, pyvista/vtk, dask from
# harness/requirements.txt) with the `velarium` Python package (pyproject.toml and setup.py at the
# root, python/velarium; docs/python.md) installed editable, so the harness runs the package's code
# as it is in the checkout. Idempotent: pip runs only when requirements.txt (or pyproject.toml,
# setup.py) changed since the last install; the system libraries VTK needs to render off screen (GL, EGL, X11 client
# libraries; no X server) are installed from Debian only if one of them is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo build --release

if [ ! -x .venv/bin/python ]; then
  if ! python3 -m venv .venv; then
    # Debian splits venv support out of python3.
    apt-get update -qq && apt-get install -y -qq python3-venv
    rm -rf .venv
    python3 -m venv .venv
  fi
fi
if ! cmp -s harness/requirements.txt .venv/.requirements.installed; then
  .venv/bin/python -m pip install --quiet --disable-pip-version-check -r harness/requirements.txt
  cp harness/requirements.txt .venv/.requirements.installed
fi
# The package, editable: it finds target/release in this checkout (docs/python.md, "Installing").
if ! cat pyproject.toml setup.py | cmp -s - .venv/.velarium.installed; then
  .venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e .
  cat pyproject.toml setup.py > .venv/.velarium.installed
fi

# VTK's wheels load libGL/libEGL (Mesa's software renderer when there is no GPU or display)
# and the X11 client libraries at run time; a minimal Debian image lacks some of them.
missing=""
for lib in libGL.so.1 libEGL.so.1 libX11.so.6 libXrender.so.1; do
  ldconfig -p | grep -q "$lib" || missing="$missing $lib"
done
if [ -n "$missing" ] || ! ls /usr/lib/*/dri/swrast_dri.so >/dev/null 2>&1; then
  echo "setup.sh: installing system libraries for off-screen rendering (missing:${missing:- the Mesa software driver})"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null && SUDO=sudo
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq libgl1 libegl1 libegl-mesa0 libgl1-mesa-dri libx11-6 libxrender1 >/dev/null
fi

# The portable FMU library (glibc 2.17, what `velarium pack` ships by default); a notice and the
# native library when its toolchain cannot be installed (docs/fmu.md, "Portable FMUs").
bash harness/portable.sh

# The Blower FMU of the coupling example (harness/blower/, docs/coupling.md): needs only a C compiler,
# takes under a second, and is rebuilt only when harness/blower/ changed.
python3 harness/blower/pack.py build/fmus >/dev/null
