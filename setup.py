"""Build hook of the `velarium` wheel (docs/python.md, "Installing"): `pip install .` here.

Everything declarative is in pyproject.toml. This file only

1. bundles the crate's binaries, the `velarium` command and `libvelarium.so`, into
   velarium/_bin/: from VELARIUM_BINARIES=DIR when it is set, else it runs
   `cargo build --release` on the crate (a no-op when the target directory is fresh) and takes
   each binary from the portable glibc 2.17 build (<target>/x86_64-unknown-linux-gnu/release,
   made by harness/portable.sh) when that is there and not older than the native one, from
   <target>/release otherwise;
2. tags the wheel py3-none-<platform> (native code, but no Python extension: any Python 3 on the
   platform can use it), the platform being manylinux_X_Y (with its legacy alias manylinux2014
   for glibc 2.17) when every bundled binary is an ELF file that needs glibc X.Y at most and no
   library outside the manylinux set, and the plain linux_<arch> tag otherwise. The ELF files
   are read here (`elf_requirements`), so the tag is what the bundled files are.

python/setup.py (`pip install ./python`) loads this file for the same hook.
"""

from __future__ import annotations

import os
import shutil
import struct
import subprocess
import sys
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.bdist_wheel import bdist_wheel
from setuptools.command.build_py import build_py

CRATE = Path(__file__).resolve().parent
BINARIES = ("velarium", "libvelarium.so")
PORTABLE_TARGET = "x86_64-unknown-linux-gnu"

# The libraries a manylinux wheel may link without bundling them (PEP 599's list for
# manylinux2014, the same for the later manylinux_2_x policies on x86_64), and the dynamic
# loader itself.
MANYLINUX_LIBRARIES = frozenset({
    "libgcc_s.so.1", "libstdc++.so.6", "libm.so.6", "libdl.so.2", "librt.so.1", "libc.so.6", "libnsl.so.1",
    "libutil.so.1", "libpthread.so.0", "libresolv.so.2", "libX11.so.6", "libXext.so.6", "libXrender.so.1",
    "libICE.so.6", "libSM.so.6", "libGL.so.1", "libgobject-2.0.so.0", "libgthread-2.0.so.0", "libglib-2.0.so.0",
    "ld-linux-x86-64.so.2", "ld-linux-aarch64.so.1",
})
GLIBC_FILES = frozenset({"libc.so.6", "libm.so.6", "libdl.so.2", "librt.so.1", "libpthread.so.0", "libresolv.so.2",
                         "libutil.so.1", "libnsl.so.1", "ld-linux-x86-64.so.2", "ld-linux-aarch64.so.1"})
ELF_MACHINES = {62: "x86_64", 183: "aarch64"}


def elf_requirements(path: Path) -> tuple[str, list[str], dict[str, set[str]]]:
    """(machine, DT_NEEDED libraries, versions needed per library) of a 64-bit little-endian
    ELF file, from its section headers: the dynamic section's DT_NEEDED entries and the GNU
    version-needs section (SHT_GNU_verneed). Raises ValueError for anything else."""
    data = path.read_bytes()
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        raise ValueError(f"{path}: not a 64-bit little-endian ELF file")
    machine = ELF_MACHINES.get(struct.unpack_from("<H", data, 18)[0], "unknown")
    shoff, = struct.unpack_from("<Q", data, 40)
    shentsize, shnum = struct.unpack_from("<HH", data, 58)
    # (type, offset, size, link) of every section
    sections = [struct.unpack_from("<4xI16xQQI", data, shoff + k * shentsize) for k in range(shnum)]

    def string(table: int, offset: int) -> str:
        start = sections[table][1] + offset
        return data[start:data.index(b"\0", start)].decode()

    needed: list[str] = []
    versions: dict[str, set[str]] = {}
    for kind, offset, size, link in sections:
        if kind == 6:  # SHT_DYNAMIC: (tag, value) pairs, DT_NEEDED = 1
            for k in range(size // 16):
                tag, value = struct.unpack_from("<qQ", data, offset + 16 * k)
                if tag == 1:
                    needed.append(string(link, value))
        elif kind == 0x6FFFFFFE:  # SHT_GNU_verneed: a list of Verneed, each with its Vernaux list
            entry = offset
            while True:
                _, count, file_name, aux, next_entry = struct.unpack_from("<HHIII", data, entry)
                library = versions.setdefault(string(link, file_name), set())
                at = entry + aux
                for _ in range(count):
                    _, _, _, name, next_aux = struct.unpack_from("<IHHII", data, at)
                    library.add(string(link, name))
                    at += next_aux
                if next_entry == 0:
                    break
                entry += next_entry
    return machine, needed, versions


def platform_tag(files: list[Path], fallback: str) -> tuple[str, str]:
    """The wheel's platform tag for these bundled binaries and why (see the module's docstring)."""
    highest = (0, 0)
    machines = set()
    for path in files:
        try:
            machine, needed, versions = elf_requirements(path)
        except (ValueError, struct.error, IndexError) as e:
            return fallback, f"{path.name} could not be read as ELF ({e})"
        machines.add(machine)
        outside = sorted(set(needed) - MANYLINUX_LIBRARIES)
        if outside:
            return fallback, f"{path.name} needs {', '.join(outside)}, outside the manylinux set"
        for library, names in versions.items():
            for name in names:
                number = name[len("GLIBC_"):].split(".")
                # Only numbered glibc versions are judged here (not GLIBC_PRIVATE, GLIBC_ABI_*,
                # nor the GCC_/GLIBCXX_ versions of libgcc_s and libstdc++, which the
                # manylinux policies bound separately): anything else gets the plain tag.
                if library not in GLIBC_FILES or not name.startswith("GLIBC_") or not all(n.isdigit() for n in number):
                    return fallback, f"{path.name} needs {library} version {name}"
                highest = max(highest, (int(number[0]), int(number[1]) if len(number) > 1 else 0))
    if len(machines) != 1 or "unknown" in machines:
        return fallback, f"the binaries are for {sorted(machines)}"
    arch = machines.pop()
    tag = f"manylinux_{highest[0]}_{highest[1]}_{arch}"
    if highest <= (2, 17):
        tag += f".manylinux2014_{arch}"
    return tag, f"highest symbol version GLIBC_{highest[0]}.{highest[1]}"


def binaries() -> dict[str, Path]:
    """The file to bundle for each of BINARIES (see the module's docstring)."""
    given = os.environ.get("VELARIUM_BINARIES")
    if given:
        directory = Path(given).resolve()
        chosen = {b: directory / b for b in BINARIES}
    else:
        if not (CRATE / "Cargo.toml").is_file():
            raise SystemExit(f"velarium: no Cargo.toml in {CRATE}: build from the repository (or its sdist), "
                             "or set VELARIUM_BINARIES to a directory holding velarium and libvelarium.so")
        if shutil.which("cargo") is None:
            raise SystemExit("velarium: cargo is not on PATH: install a Rust toolchain, or set VELARIUM_BINARIES "
                             "to a directory holding velarium and libvelarium.so")
        jobs = os.environ.get("VELARIUM_CARGO_JOBS")
        command = ["cargo", "build", "--release", "--manifest-path", str(CRATE / "Cargo.toml")]
        if jobs:
            command += ["-j", jobs]
        subprocess.run(command, check=True)
        target = os.environ.get("CARGO_TARGET_DIR")
        target_dir = (Path(target) if target else CRATE / "target").resolve()
        chosen = {}
        for b in BINARIES:
            native = target_dir / "release" / b
            portable = target_dir / PORTABLE_TARGET / "release" / b
            fresh = portable.is_file() and native.is_file() and portable.stat().st_mtime >= native.stat().st_mtime
            chosen[b] = portable if fresh else native
    missing = [str(p) for p in chosen.values() if not p.is_file()]
    if missing:
        raise SystemExit(f"velarium: missing {', '.join(missing)}")
    return chosen


#: the platform tag of the binaries build_py bundled, for bdist_wheel
_BUNDLED: dict[str, str] = {}


class BuildPyWithBinaries(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            # An editable install runs from the checkout and finds the target directory there.
            return
        bundle = Path(self.build_lib) / "velarium" / "_bin"
        bundle.mkdir(parents=True, exist_ok=True)
        chosen = binaries()
        for name, source in chosen.items():
            shutil.copy2(source, bundle / name)
        tag, why = platform_tag([bundle / b for b in BINARIES], "")
        _BUNDLED["tag"] = tag
        print(f"velarium: bundled {', '.join(str(p) for p in chosen.values())}; {why}; platform tag "
              f"{tag or 'of this machine'}", file=sys.stderr)


class PlatformDistribution(Distribution):
    def has_ext_modules(self):
        return True


class AnyPythonWheel(bdist_wheel):
    """Tagged py3-none-<platform>: the binaries are tied to the platform, not to a Python ABI."""

    def get_tag(self):
        _, _, platform = super().get_tag()
        return "py3", "none", _BUNDLED.get("tag") or platform


COMMANDS = {"build_py": BuildPyWithBinaries, "bdist_wheel": AnyPythonWheel}

if __name__ == "__main__":
    setup(cmdclass=COMMANDS, distclass=PlatformDistribution)
