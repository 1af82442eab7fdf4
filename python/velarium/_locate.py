"""Where the `velarium` command and `libvelarium.so` are.

In this order:

1. ``VELARIUM_HOME``: a directory holding both binaries, or a checkout (its ``target/release``);
2. the binaries bundled in the wheel (``velarium/_bin``, found with ``importlib.resources``);
3. the checkout this package sits in (an editable install: ``<checkout>/target/release``, or
   ``$CARGO_TARGET_DIR/release``).

The first that has the command wins; nothing found is an error that names all three. The FMU
library is the one beside the command, except in a checkout's layout where the portable glibc
2.17 build (``<target>/x86_64-unknown-linux-gnu/release/libvelarium.so``, harness/portable.sh)
is there and not older: then that one, the file `velarium pack` ships by default.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

COMMAND = "velarium"
LIBRARY = "libvelarium.so"
PORTABLE_TARGET = "x86_64-unknown-linux-gnu"


def _candidates() -> list[tuple[str, Path]]:
    found: list[tuple[str, Path]] = []
    home = os.environ.get("VELARIUM_HOME")
    if home:
        found.append(("VELARIUM_HOME", Path(home)))
        found.append(("VELARIUM_HOME (a checkout)", Path(home) / "target" / "release"))
    bundled = resources.files("velarium") / "_bin"
    if isinstance(bundled, Path):
        found.append(("the wheel's velarium/_bin", bundled))
    checkout = Path(__file__).resolve().parent.parent.parent
    if (checkout / "Cargo.toml").is_file():
        target = os.environ.get("CARGO_TARGET_DIR")
        if target:
            found.append(("CARGO_TARGET_DIR", Path(target) / "release"))
        found.append(("the checkout", checkout / "target" / "release"))
    return found


def binaries_dir() -> Path:
    """The directory of the `velarium` command (and of libvelarium.so beside it)."""
    tried = []
    for label, directory in _candidates():
        if (directory / COMMAND).is_file():
            return directory.resolve()
        tried.append(f"{label}: {directory}")
    raise FileNotFoundError(
        "velarium: the `velarium` command was not found; looked in "
        + ("; ".join(tried) or "nowhere (no VELARIUM_HOME, no bundled binaries, no checkout)")
        + ". Install the wheel (pip install . at the repository's root), build the checkout (cargo build --release) "
        "or set VELARIUM_HOME to a directory holding velarium and libvelarium.so"
    )


def command() -> Path:
    """The `velarium` command this package runs."""
    return binaries_dir() / COMMAND


def library() -> Path:
    """The FMU library `velarium pack` copies into archives: libvelarium.so beside the command,
    or its portable build when current (src/pack.rs, choose_library: the same rule)."""
    path = binaries_dir() / LIBRARY
    if not path.is_file():
        raise FileNotFoundError(f"velarium: {path} is missing (the `velarium` command is there, its library is not)")
    portable = path.parent.parent / PORTABLE_TARGET / path.parent.name / LIBRARY
    if portable.is_file() and portable.stat().st_mtime >= path.stat().st_mtime:
        return portable
    return path
