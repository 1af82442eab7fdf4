"""The Python package (pyproject.toml and setup.py at the root, python/velarium; docs/python.md):
`pip install .` at the repository's root into a fresh virtual environment runs every Python block
of docs/python.md with the bundled command; the wheel's platform tag is what its binaries need
(manylinux2014 for the portable glibc 2.17 build, checked with objdump, not with setup.py's own
ELF reader); the sdist holds the crate and the package and builds a wheel; `pip install ./python`
builds the same wheel; bad input is a ValueError naming the field; `python -m velarium.run` and
`python -m velarium.sweep` work.

The fresh environment is made without pip and without the project's .venv on its path; the
package goes in with `pip --python FRESH install --no-deps --no-index --no-build-isolation .`
(run in the repository's root: setup.py runs `cargo build --release`, a no-op after
`bash .ci/run`), and numpy, fmpy, Dask and setuptools come from .venv's site-packages through a
path file (a path file's directory is on sys.path, but the path files in it, such as .venv's
editable install of velarium, are not run), so nothing is downloaded. The sdist's wheel is built
with VELARIUM_BINARIES (the crate's build from it takes minutes: measured by hand, docs/python.md).
"""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy as np
import pytest

import velarium
import velarium_run as vr
from velarium.sweep import sweep

DOC = vr.ROOT / "docs" / "python.md"


def examples() -> str:
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), re.S)
    assert len(blocks) >= 6, "docs/python.md lost its examples"
    return "\n\n".join(blocks)


def clean_env(**extra: str) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("VELARIUM_HOME", "PYTHONPATH", "CARGO_TARGET_DIR", "VIRTUAL_ENV")}
    env.update(extra)
    return env


def highest_glibc(path: Path) -> tuple[int, ...]:
    """The highest GLIBC_x.y symbol version ``path`` needs, read by objdump (binutils)."""
    dump = subprocess.run(["objdump", "-T", str(path)], capture_output=True, text=True, check=True).stdout
    versions = {tuple(int(n) for n in v.split(".")) for v in re.findall(r"GLIBC_(\d+(?:\.\d+)*)", dump)}
    return max(versions)


def portable_build() -> Path | None:
    """The portable glibc 2.17 build's directory when both binaries are there and not older
    than the native ones (what setup.py bundles then), else None."""
    portable = vr.VELARIUM.parent.parent / "x86_64-unknown-linux-gnu" / "release"
    for name in ("velarium", "libvelarium.so"):
        p, n = portable / name, vr.VELARIUM.parent / name
        if not p.is_file() or p.stat().st_mtime < n.stat().st_mtime:
            return None
    return portable


@pytest.fixture(scope="module")
def fresh(tmp_path_factory) -> Path:
    """The python of a fresh virtual environment into which `pip install .` was run at the
    repository's root."""
    library = vr.VELARIUM.parent / "libvelarium.so"
    if not vr.VELARIUM.is_file() or not library.is_file():
        pytest.skip(f"{vr.VELARIUM} or {library} is missing: run `cargo build --release`")
    root = tmp_path_factory.mktemp("fresh")
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(root / "venv")], check=True, timeout=120)
    python = root / "venv" / "bin" / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    (Path(purelib) / "velarium-test-deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    install = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index",
         "--no-build-isolation", "."],
        capture_output=True, text=True, cwd=vr.ROOT, timeout=900,
        env=clean_env(CARGO_TARGET_DIR=str(vr.VELARIUM.parent.parent), VELARIUM_CARGO_JOBS="1"),
    )
    assert install.returncode == 0, install.stdout + install.stderr
    return python


def site_packages(python: Path) -> Path:
    return Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['platlib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())


def test_the_wheel_bundles_and_runs_its_own_command(fresh, tmp_path):
    code = ("import velarium, sys; print(velarium.__file__); print(velarium.command()); print(velarium.library()); "
            "print(velarium.load_scene(sys.argv[1]).summary)")
    run = subprocess.run([str(fresh), "-c", code, str(vr.SCENES / "PrestressedCable" / "scene.json")],
                         capture_output=True, text=True, cwd=tmp_path, env=clean_env(), timeout=120)
    assert run.returncode == 0, run.stderr
    module, command, library, summary = run.stdout.splitlines()
    venv = fresh.parent.parent
    for path in (module, command, library):
        assert Path(path).is_relative_to(venv), path
    bundled = portable_build() or vr.VELARIUM.parent
    assert Path(command).read_bytes() == (bundled / "velarium").read_bytes()
    assert Path(library).read_bytes() == (bundled / "libvelarium.so").read_bytes()
    assert os.access(command, os.X_OK)
    assert summary.startswith("ok: PrestressedCable, 3 nodes")
    # VELARIUM_HOME (a checkout) comes before the bundled binaries.
    run = subprocess.run([str(fresh), "-c", "import velarium; print(velarium.command())"], capture_output=True, text=True,
                         env=clean_env(VELARIUM_HOME=str(vr.ROOT)), timeout=120)
    assert run.returncode == 0, run.stderr
    assert Path(run.stdout.strip()).resolve() == vr.VELARIUM.resolve()


def test_the_docs_examples_run_in_the_fresh_environment(fresh, tmp_path):
    script = tmp_path / "examples.py"
    script.write_text(examples())
    run = subprocess.run([str(fresh), str(script)], capture_output=True, text=True, cwd=tmp_path, env=clean_env(), timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    # What the blocks print is what their comments show (runs of spaces as one).
    shown = [" ".join(c.split()) for c in re.findall(r"print\(.*\)\s+# (.*)", examples())]
    printed = [" ".join(line.split()) for line in run.stdout.splitlines()]
    assert len(shown) == 7
    for comment in shown:
        if "(...)" in comment:
            assert any(line.startswith(comment.split(" (...)")[0]) for line in printed), comment
        else:
            assert comment in printed, f"{comment!r} not in {printed}"


def test_the_wheel_is_tagged_by_the_glibc_its_binaries_need(fresh):
    """The installed wheel's platform tag against objdump's reading of the bundled binaries:
    manylinux_2_17 + manylinux2014 when they need glibc 2.17 at most (the portable build, which
    `bash .ci/run` makes and which must then be what is bundled), the plain linux tag when a
    binary needs more (the native build: glibc 2.35 and libgcc_s here)."""
    if shutil.which("objdump") is None:
        pytest.skip("objdump (binutils) is not installed: it reads the binaries' GLIBC versions here")
    site = site_packages(fresh)
    wheel = (site / "velarium-0.1.0.dist-info" / "WHEEL").read_text()
    tags = sorted(line.split(": ", 1)[1] for line in wheel.splitlines() if line.startswith("Tag: "))
    highest = max(highest_glibc(site / "velarium" / "_bin" / name) for name in ("velarium", "libvelarium.so"))
    print("bundled binaries need GLIBC_" + ".".join(map(str, highest)), "; tags", tags)
    if portable_build() is not None:
        assert highest == (2, 17)
    if highest <= (2, 17):
        assert tags == ["py3-none-manylinux2014_x86_64", "py3-none-manylinux_2_17_x86_64"]
    else:
        assert tags == ["py3-none-linux_x86_64"]


def test_the_hooks_elf_reader_agrees_with_objdump():
    """setup.py's own ELF reader (what the tag is decided on) against binutils: the same GLIBC
    versions needed, on the native and the portable binaries; the native ones (glibc 2.35,
    libgcc_s) get the plain tag, the portable ones manylinux2014."""
    import importlib.util

    if shutil.which("objdump") is None or shutil.which("readelf") is None:
        pytest.skip("objdump/readelf (binutils) are not installed")
    spec = importlib.util.spec_from_file_location("velarium_wheel_hook", vr.ROOT / "setup.py")
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    checked = 0
    for directory in (vr.VELARIUM.parent, vr.VELARIUM.parent.parent / "x86_64-unknown-linux-gnu" / "release"):
        files = [directory / name for name in ("velarium", "libvelarium.so")]
        if not all(f.is_file() for f in files):
            continue
        for f in files:
            machine, needed, versions = hook.elf_requirements(f)
            ours = {v for names in versions.values() for v in names if v.startswith("GLIBC_")}
            dump = subprocess.run(["objdump", "-T", str(f)], capture_output=True, text=True, check=True).stdout
            assert ours == set(re.findall(r"\b(GLIBC_[0-9.]+)\b", dump)), f
            dynamic = subprocess.run(["readelf", "-d", str(f)], capture_output=True, text=True, check=True).stdout
            assert needed == re.findall(r"\(NEEDED\)\s+Shared library: \[(.*?)\]", dynamic), f
            assert machine == "x86_64"
            checked += 1
        tag, why = hook.platform_tag(files, "linux_x86_64")
        highest = max(highest_glibc(f) for f in files)
        print(directory, tag, why)
        if highest <= (2, 17):
            assert tag == "manylinux_2_17_x86_64.manylinux2014_x86_64", why
        elif any("libgcc_s.so.1" in hook.elf_requirements(f)[1] for f in files):
            assert tag == "linux_x86_64", why
    if checked == 0:
        pytest.skip(f"no binaries in {vr.VELARIUM.parent}: run `cargo build --release`")


def test_the_root_and_python_projects_declare_the_same_package():
    import tomllib

    root = tomllib.loads((vr.ROOT / "pyproject.toml").read_text())
    python = tomllib.loads((vr.ROOT / "python" / "pyproject.toml").read_text())
    assert root["build-system"] == python["build-system"]
    assert root["project"].pop("readme") == "python/README.md" and python["project"].pop("readme") == "README.md"
    assert root["project"] == python["project"]
    assert root["tool"]["setuptools"]["package-dir"] == {"": "python"}


def _wheel_names(path: Path) -> list[str]:
    import zipfile

    with zipfile.ZipFile(path) as z:
        return sorted(n for n in z.namelist() if ".dist-info/" not in n)


def test_the_sdist_holds_the_crate_and_builds_the_wheel(tmp_path):
    """The root's sdist: every source file of the crate (git ls-files) and of the package, no
    build output; cargo reads its manifest; a wheel builds from it (with VELARIUM_BINARIES, so
    cargo is not run here: the crate's build from the sdist is measured in docs/python.md) and
    holds what `pip wheel ./python` puts in its wheel."""
    import tarfile

    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    build = subprocess.run([sys.executable, "-c", "import sys; from setuptools import build_meta as b; "
                            "print(b.build_sdist(sys.argv[1]))", str(tmp_path / "sdist")],
                           capture_output=True, text=True, cwd=vr.ROOT, env=clean_env(), timeout=300)
    assert build.returncode == 0, build.stderr
    sdist = tmp_path / "sdist" / build.stdout.split()[-1]
    assert sdist.name == "velarium-0.1.0.tar.gz"
    with tarfile.open(sdist) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
        tar.extractall(tmp_path / "unpacked", filter="data")
    listed = subprocess.run(["git", "ls-files", "src", "Cargo.toml", "Cargo.lock", "python/velarium"],
                            capture_output=True, text=True, cwd=vr.ROOT)
    if listed.returncode == 0 and listed.stdout.strip():
        wanted = set(listed.stdout.split())
    else:  # not a git checkout: the files on disk
        wanted = {str(p.relative_to(vr.ROOT)) for p in (vr.ROOT / "src").rglob("*.rs")} | {"Cargo.toml", "Cargo.lock"}
    assert wanted <= names, sorted(wanted - names)[:10]
    assert {"pyproject.toml", "setup.py", "python/README.md", "PKG-INFO"} <= names
    assert not [n for n in names if n.split("/")[0] in ("target", "build", "harness", "tests", ".venv")]
    assert sdist.stat().st_size < 2_000_000
    unpacked = tmp_path / "unpacked" / "velarium-0.1.0"
    if shutil.which("cargo"):
        meta = subprocess.run(["cargo", "metadata", "--format-version", "1", "--no-deps", "--offline",
                               "--manifest-path", str(unpacked / "Cargo.toml")], capture_output=True, text=True, timeout=120)
        assert meta.returncode == 0, meta.stderr
        kinds = sorted(k for t in json.loads(meta.stdout)["packages"][0]["targets"] for k in t["kind"])
        assert {"bin", "cdylib", "rlib"} <= set(kinds), kinds
    wheels = {}
    for label, source in (("sdist", sdist), ("python", vr.ROOT / "python")):
        out = tmp_path / f"wheels-{label}"
        run = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--quiet",
                              str(source), "--wheel-dir", str(out)], capture_output=True, text=True, timeout=300,
                             env=clean_env(VELARIUM_BINARIES=str(portable_build() or vr.VELARIUM.parent)))
        assert run.returncode == 0, run.stdout + run.stderr
        [wheels[label]] = out.glob("velarium-0.1.0-py3-none-*.whl")
    assert wheels["sdist"].name == wheels["python"].name
    names = _wheel_names(wheels["sdist"])
    assert names == _wheel_names(wheels["python"])
    assert {"velarium/_bin/velarium", "velarium/_bin/libvelarium.so", "velarium/__init__.py", "velarium/py.typed",
            "velarium/couple.py"} <= set(names)


# ----------------------------------------------------------------------------- named errors

@pytest.fixture
def cable_fmu() -> Path:
    path = vr.FMU_DIR / "PrestressedCable.fmu"
    if not path.is_file():
        pytest.skip(f"{path} is missing: run `bash .ci/run`")
    return path


@pytest.mark.parametrize("loads, message", [
    ({"F": [0.0, 1.0]}, "loads: no 'time' column"),
    ({"time": [0.0, 1.0], "P": [0.0, float("nan")]}, "loads.P, row 1: nan is not a finite number"),
    ({"time": [0.0, 1.0, 1.0], "P": [0.0, 1.0, 2.0]}, "loads.time, row 2: 1.0 does not come after row 1's 1.0"),
    ({"time": [0.0, 1.0], "P": [0.0]}, "loads.P: 1 rows, but 'time' has 2"),
    ({"time": [0.0, 1.0], "P": ["a", "b"]}, "loads.P: not numbers"),
    (np.zeros(3), "loads: a plain array has no column names"),
])
def test_a_bad_load_table_is_named(loads, message):
    with pytest.raises(ValueError) as e:
        velarium.as_table(loads)
    assert str(e.value).startswith(message), str(e.value)


def test_bad_arguments_name_the_field(cable_fmu, tmp_path):
    scene = vr.SCENES / "PrestressedCable" / "scene.json"
    with pytest.raises(ValueError, match=r"^loads\.Q: PrestressedCable has no input 'Q' \(inputs: \['P'\]\)"):
        velarium.solve(scene, {"time": [0.0, 1.0], "Q": [0.0, 1.0]})
    with pytest.raises(ValueError, match=r"^loads\.time: fmpy steps on a uniform grid"):
        velarium.run_fmu(cable_fmu, {"time": [0.0, 0.5, 2.0], "P": [0.0, 1.0, 2.0]})
    with pytest.raises(ValueError, match=r"^start_values\.EB: PrestressedCable has no parameter or input 'EB'"):
        velarium.run_fmu(cable_fmu, {"time": [0.0, 0.5], "P": [0.0, 1.0]}, start_values={"EB": 1.0})
    with pytest.raises(ValueError, match=r"^scene: .*nowhere\.json: no such file"):
        velarium.load_scene(tmp_path / "nowhere.json")
    with pytest.raises(ValueError, match=r"^workers: 0 is not a positive whole number"):
        sweep(cable_fmu, {"P": [1.0]}, workers=0)
    with pytest.raises(ValueError, match=r"^'Q' is not an input or a parameter of PrestressedCable"):
        sweep(cable_fmu, {"Q": [1.0]}, scheduler="synchronous", progress=False)
    with pytest.raises(ValueError, match=r"^fmi: 4 is not 2, 3 or 'both'"):
        velarium.pack(scene, tmp_path, fmi=4)


def test_a_failed_step_keeps_the_aligned_rows_before_it(tmp_path):
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing")
    import fmi_support as fs

    fmu = fs.debug_variant("PrestressedCable", tmp_path / "variant", vr.VELARIUM, fail_after_time=0.55)
    table = {"time": [0.0, 0.25, 0.5, 0.75, 1.0], "P": [0.0, 1000.0, 2000.0, 3000.0, 4000.0]}
    with pytest.raises(velarium.RunEndedEarly) as e:
        velarium.run_fmu(fmu, table)
    # The step from 0.5 to 0.75 fails (it ends after 0.55): rows 0 and 1 (loads of t = 0, 0.25)
    # are the equilibria recorded before it, aligned like solve's.
    rows = e.value.rows
    assert list(rows["time"]) == [0.0, 0.25]
    solved = velarium.solve(vr.SCENES / "PrestressedCable" / "scene.json", {k: v[:2] for k, v in table.items()})
    assert list(rows["midspan_uz"]) == list(solved["midspan_uz"])


# ----------------------------------------------------------------------------- the modules

def test_python_m_velarium_sweep_and_run(cable_fmu, tmp_path):
    out = tmp_path / "sweep"
    run = subprocess.run([sys.executable, "-m", "velarium.sweep", str(cable_fmu), "--grid", "P=2000,6000", "--steps", "2",
                          "--scheduler", "synchronous", "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "2 runs (0 ended early with Discard)" in run.stdout
    with open(out / "sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["P"]) for r in rows if r["time"] == "1.5"] == [2000.0, 6000.0]
    run = subprocess.run([sys.executable, "-m", "velarium.run", str(cable_fmu), "--out", str(tmp_path / "run")],
                         capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "run" / "PrestressedCable.png").stat().st_size > 0
    assert (tmp_path / "run" / "vtk" / "PrestressedCable.pvd").is_file()
    from velarium.sweep import main as sweep_main

    with pytest.raises(SystemExit) as e:
        sweep_main([str(cable_fmu), "--grid", "Q=1"])
    assert "'Q' is not an input or a parameter of PrestressedCable" in str(e.value.code)


def test_a_dataframe_is_a_load_table_and_a_result_becomes_one():
    import pandas as pd  # in harness/requirements.txt: this test runs in CI
    frame = pd.DataFrame({"time": [0.0, 0.5], "P": [0.0, 2000.0]})
    table = velarium.as_table(frame)
    assert table.dtype.names == ("time", "P") and list(table["P"]) == [0.0, 2000.0]
    back = velarium.to_pandas(table)
    assert list(back.columns) == ["time", "P"] and list(back["P"]) == [0.0, 2000.0]


@pytest.mark.parametrize("name, grid", [("PrestressedCable", {"P": [2000.0, 6000.0]}),
                                         ("HenckyDisc", {"pressure": [10.0, 40.0]})])
def test_the_solve_engine_gives_the_fmu_sweeps_rows(name, grid):
    """engine='solve' (`velarium solve` per run, no FMU) records the same tidy rows as the FMU
    sweep, bit for bit: the grid, the lag and the loads carried are mapped, not approximated."""
    fmu = vr.FMU_DIR / f"{name}.fmu"
    if not fmu.is_file():
        pytest.skip(f"{fmu} is missing: run `bash .ci/run`")
    fmu_rows = sweep(fmu, grid, steps=3, scheduler="synchronous", progress=False).rows
    solve_rows = sweep(fmu, grid, steps=3, scheduler="synchronous", progress=False, engine="solve").rows
    assert len(fmu_rows) == 2 * 5
    assert [list(r) for r in solve_rows] == [list(r) for r in fmu_rows]
    assert solve_rows == fmu_rows
    with pytest.raises(ValueError, match=r"^engine: 'ffi' is not 'fmu' or 'solve'"):
        sweep(fmu, grid, engine="ffi")


def test_the_solve_engine_ends_a_run_where_the_fmu_discards(tmp_path):
    """examples/SleeveDrawstring.json cannot be taken past 2P = 0.19 N (docs/harness.md): a run to
    1 N ends early through both engines, at the same row, with the same rows before it."""
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing")
    fmu = velarium.pack(vr.ROOT / "examples" / "SleeveDrawstring.json", tmp_path, fmi=2)[0]
    grid = {"force_2P": [0.1, 1.0]}
    fmu_rows = sweep(fmu, grid, steps=5, scheduler="synchronous", progress=False).rows
    solve_rows = sweep(fmu, grid, steps=5, scheduler="synchronous", progress=False, engine="solve").rows
    assert [r["status"] for r in fmu_rows if r["run"] == 0] == ["ok"] * 7
    failed = [r for r in fmu_rows if r["run"] == 1]
    assert {r["status"] for r in failed} == {"discard"} and len(failed) < 7
    assert solve_rows == fmu_rows


def test_a_sweep_without_dask_names_the_extra(cable_fmu, monkeypatch):
    """A plain `pip install .` brings no Dask (the `sweep` extra does): a sweep then says which
    extra to install rather than failing on a bare ModuleNotFoundError (found 2026-11-28 in a
    fresh venv, where the docs' sweep example stopped at `import dask.bag`)."""
    for name in [m for m in sys.modules if m == "dask" or m.startswith("dask.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "dask", None)  # import dask -> ImportError
    with pytest.raises(ImportError, match=r"velarium\[sweep\]"):
        sweep(cable_fmu, {"P": [25.0, 50.0]}, steps=2, scheduler="synchronous", progress=False)
