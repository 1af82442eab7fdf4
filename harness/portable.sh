#!/usr/bin/env bash
# The portable FMU library and command (docs/fmu.md, "Portable FMUs: the glibc 2.17 build"):
# libvelarium.so and the `velarium` command built with cargo-zigbuild for
# x86_64-unknown-linux-gnu.2.17 (zig's linker and glibc 2.17's symbol stubs, manylinux2014), a
# second build of the cdylib and the binary. `velarium pack` ships the library by default from
# <target dir>/x86_64-unknown-linux-gnu/release/libvelarium.so when it is not older than the
# native library (src/pack.rs, choose_library); the Python wheel (setup.py) bundles both files
# from there on the same rule, and is then tagged manylinux2014.
#
# The toolchain comes from PyPI (ziglang, cargo-zigbuild, pinned below) into .venv. When it
# cannot be installed (no PyPI, an unsupported platform), this prints a notice and exits 0: the
# FMUs are then packed with the native library (glibc 2.35 here), and `velarium pack` says so.
# A build that fails with the toolchain present is an error (exit 1).
# Usage: bash harness/portable.sh (after harness/setup.sh's .venv; setup.sh runs it).
set -euo pipefail
cd "$(dirname "$0")/.."

TARGET=x86_64-unknown-linux-gnu
notice() {
  echo "portable.sh: NOTICE: $1; the FMUs will hold the native library, which needs glibc 2.35 or newer (Debian 12, Ubuntu 22.04), not glibc 2.17 (docs/fmu.md, \"Portable FMUs\")" >&2
  exit 0
}

[ "$(uname -m)-$(uname -s)" = "x86_64-Linux" ] || notice "the portable build targets x86_64 Linux, this is $(uname -m) $(uname -s)"
if ! .venv/bin/python -m pip install --quiet --disable-pip-version-check "ziglang==0.17.1" "cargo-zigbuild==0.24.0"; then
  notice "ziglang and cargo-zigbuild could not be installed from PyPI"
fi

start=$(date +%s)
PATH="$PWD/.venv/bin:$PATH" cargo zigbuild --release --lib --bins --target "$TARGET.2.17"
dir=$(cargo metadata --format-version 1 --no-deps | .venv/bin/python -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')
for file in libvelarium.so velarium; do
  path="$dir/$TARGET/release/$file"
  highest=$(objdump -T "$path" 2>/dev/null | grep -o 'GLIBC_[0-9.]*' | sort -u -V | tail -1 || true)
  echo "portable.sh: $path (highest symbol version ${highest:-unknown: objdump missing})"
done
echo "portable.sh: built in $(($(date +%s) - start)) s"
