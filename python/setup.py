"""Build hook of the wheel: bundle the crate's release binaries into velarium/_bin/.

Everything declarative is in pyproject.toml. This file only (1) runs `cargo build --release` on
the crate one directory up (or takes the binaries from VELARIUM_BINARIES=DIR) and copies
`velarium` and `libvelarium.so` into the built package, and (2) marks the wheel as
platform-specific (it holds native code, but no Python extension: any Python 3 on the same
platform can use it), so pip never installs it on another platform.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.bdist_wheel import bdist_wheel
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
CRATE = HERE.parent
BINARIES = ("velarium", "libvelarium.so")


def release_dir() -> Path:
    given = os.environ.get("VELARIUM_BINARIES")
    if given:
        directory = Path(given).resolve()
    else:
        if not (CRATE / "Cargo.toml").is_file():
            raise SystemExit(f"velarium: no Cargo.toml in {CRATE}: build from the repository's python/ directory "
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
        directory = (Path(target) if target else CRATE / "target").resolve() / "release"
    missing = [b for b in BINARIES if not (directory / b).is_file()]
    if missing:
        raise SystemExit(f"velarium: {directory} lacks {', '.join(missing)}")
    return directory


class BuildPyWithBinaries(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            # An editable install runs from the checkout and finds target/release there.
            return
        source = release_dir()
        bundle = Path(self.build_lib) / "velarium" / "_bin"
        bundle.mkdir(parents=True, exist_ok=True)
        for name in BINARIES:
            shutil.copy2(source / name, bundle / name)


class PlatformDistribution(Distribution):
    def has_ext_modules(self):
        return True


class AnyPythonWheel(bdist_wheel):
    """Tagged py3-none-<platform>: the binaries are tied to the platform, not to a Python ABI."""

    def get_tag(self):
        _, _, platform = super().get_tag()
        return "py3", "none", platform


setup(cmdclass={"build_py": BuildPyWithBinaries, "bdist_wheel": AnyPythonWheel}, distclass=PlatformDistribution)
