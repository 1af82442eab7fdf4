"""Every example in every `--help` text runs (issue 29 point 5; docs/harness.md, "Running your own
scene").

The commands: `velarium` and each of its subcommands, the package's `python -m velarium.run` and
`python -m velarium.sweep`, and the harness's scripts with a command line (run_main.py,
screenshot.py, speed_error.py, plot_elements.py, sleeve_table.py, sweep_throughput.py). An
example is a line indented by two spaces under a line `Examples:` of the help text, up to the
next blank line (a line in parentheses is a comment on the one before). Each example runs as
written through bash, from a scratch directory that holds the checkout's `modelDescription/`,
`examples/`, `harness/`, `python/`, `target/` and `.venv/` (links) and an empty `build/`, with
`velarium` and `python` on PATH meaning this build's command and the harness's interpreter; it
must exit 0. Files an example reads must exist: the shipped scenes and load tables, or what the
fixture writes first (the WindSquare series and per-element table, as the `velarium solve`
examples write them). The examples use small shipped scenes, so each takes seconds.
A help text that names a file that does not exist fails here. The help texts must also carry at
least one example each for the commands in WITH_EXAMPLES.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import velarium_run as vr

ROOT = vr.ROOT
PYTHON = Path(sys.executable)
SUBCOMMANDS = ["pack", "solve", "formfind", "check", "describe", "schema"]
SCRIPTS = ["run_main.py", "screenshot.py", "speed_error.py", "plot_elements.py", "sleeve_table.py", "sweep_throughput.py"]
# Commands whose help must show how to run them (the others are benchmarks or the main job's
# steps, whose help gives the synopsis only).
WITH_EXAMPLES = {"velarium", *(f"velarium {c}" for c in SUBCOMMANDS), "python -m velarium.run",
                 "python -m velarium.sweep", "harness/run_main.py", "harness/screenshot.py",
                 "harness/speed_error.py", "harness/plot_elements.py"}


def help_commands() -> list[tuple[str, list[str]]]:
    commands = [("velarium", [str(vr.VELARIUM), "--help"])]
    commands += [(f"velarium {c}", [str(vr.VELARIUM), c, "--help"]) for c in SUBCOMMANDS]
    commands += [(f"python -m velarium.{m}", [str(PYTHON), "-m", f"velarium.{m}", "--help"]) for m in ("run", "sweep")]
    commands += [(f"harness/{s}", [str(PYTHON), str(ROOT / "harness" / s), "--help"]) for s in SCRIPTS]
    return commands


def examples(text: str) -> list[str]:
    found = []
    lines = text.splitlines()
    for k, line in enumerate(lines):
        if line.strip() != "Examples:":
            continue
        for follow in lines[k + 1:]:
            if not follow.strip():
                break
            if follow.startswith("  ") and not follow.strip().startswith("("):
                found.append(follow.strip())
    return found


def env() -> dict:
    e = dict(os.environ)
    e["PYTHONPATH"] = os.pathsep.join([str(ROOT / "python"), str(ROOT / "harness"), e.get("PYTHONPATH", "")])
    e["VELARIUM_HOME"] = str(vr.VELARIUM.parent)
    e.setdefault("OMP_NUM_THREADS", "1")
    return e


def help_text(argv: list[str]) -> str:
    run = subprocess.run(argv, capture_output=True, text=True, env=env(), cwd=ROOT, timeout=120)
    assert run.returncode == 0, f"{' '.join(argv)} failed:\n{run.stderr}"
    return run.stdout


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    velarium = vr.VELARIUM
    if not velarium.is_file():
        pytest.skip(f"{velarium} is missing: run `cargo build --release`")
    root = tmp_path_factory.mktemp("help_examples")
    for name in ("modelDescription", "examples", "harness", "python", "target", ".venv"):
        (root / name).symlink_to(ROOT / name)
    (root / "build").mkdir()
    bin_dir = root / "bin"
    bin_dir.mkdir()
    (bin_dir / "velarium").symlink_to(velarium)
    # A wrapper, not a link: a link to the venv's interpreter from outside the venv would not
    # find the venv's site-packages.
    (bin_dir / "python").write_text(f'#!/bin/sh\nexec "{PYTHON}" "$@"\n')
    (bin_dir / "python").chmod(0o755)
    # What the examples of plot_elements.py and screenshot.py read (the `velarium solve` examples
    # write the same files).
    subprocess.run([str(velarium), "solve", "examples/WindSquare.json", "--loads", "examples/WindSquare-loads.csv",
                    "--vtk", "build/WindSquare", "--elements", "build/WindSquare-elements.csv", "--quiet",
                    "--out", "build/WindSquare.csv"], cwd=root, check=True, capture_output=True)
    return root


def all_examples() -> list:
    if not vr.VELARIUM.is_file():
        return [pytest.param(None, None, marks=pytest.mark.skip(reason=f"{vr.VELARIUM} is missing: run `cargo build --release`"))]
    params = []
    for name, argv in help_commands():
        for example in examples(help_text(argv)):
            params.append(pytest.param(name, example, id=f"{name}: {example[:60]}"))
    return params


def test_every_command_shows_examples(velarium):
    missing = [name for name, argv in help_commands() if name in WITH_EXAMPLES and not examples(help_text(argv))]
    assert not missing, f"no `Examples:` section in the --help of {missing}"


def test_the_extractor_reads_an_examples_section():
    text = "usage: x\n\nExamples:\n  velarium check a.json\n  (prints ok)\n  velarium schema > s.json\n\nmore\n  velarium no\n"
    assert examples(text) == ["velarium check a.json", "velarium schema > s.json"]


@pytest.mark.parametrize("command, example", all_examples())
def test_help_example_runs(command, example, scratch):
    assert command is not None
    # Every file argument an example names under the checkout's folders exists (the help text
    # names no file a user would not have).
    for path in re.findall(r"(?:modelDescription|examples)/[\w./-]+", example):
        assert (scratch / path).exists(), f"`{command} --help` names {path}, which does not exist"
    e = env()
    e["PATH"] = f"{scratch / 'bin'}{os.pathsep}{e['PATH']}"
    run = subprocess.run(["bash", "-c", example], cwd=scratch, env=e, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, f"`{example}` (from `{command} --help`) exited {run.returncode}:\n{run.stdout[-1500:]}\n{run.stderr[-3000:]}"
