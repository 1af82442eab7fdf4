"""Fixtures of the FMU harness. It builds nothing: `bash .ci/run` builds target/release/velarium
and packs every shipped scene into build/fmus/ before it runs pytest. Missing pieces make the
tests that need them skip, each with the reason."""

from __future__ import annotations

from pathlib import Path

import pytest

import velarium_run as vr


def pytest_generate_tests(metafunc):
    if "model" in metafunc.fixturenames:
        names = vr.shipped_models()
        if names:
            metafunc.parametrize("model", names)
        else:
            reason = f"no shipped scenes: {vr.SCENES}/<Name>/scene.json is missing"
            metafunc.parametrize("model", [pytest.param(None, marks=pytest.mark.skip(reason=reason))])


@pytest.fixture
def scene(model) -> Path:
    return vr.SCENES / model / "scene.json"


@pytest.fixture
def fmu(model) -> Path:
    path = vr.FMU_DIR / f"{model}.fmu"
    if not path.is_file():
        pytest.skip(f"{path} is missing: run `bash .ci/run` (or `velarium pack {vr.SCENES}/{model}/scene.json --out {vr.FMU_DIR}`)")
    return path


@pytest.fixture
def velarium() -> Path:
    if not vr.VELARIUM.is_file():
        pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
    return vr.VELARIUM


@pytest.fixture
def model_description(fmu):
    import fmpy

    return fmpy.read_model_description(str(fmu))


@pytest.fixture(scope="session")
def extract_root(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("extracted")


@pytest.fixture
def unzipdir(fmu, extract_root) -> Path:
    """The FMU unzipped once per session (for the low-level FMU2Slave tests)."""
    import fmi_support

    return fmi_support.extracted(fmu, extract_root)


@pytest.fixture(scope="session")
def debug_fmus(tmp_path_factory):
    """debug_fmus(model, **switches) -> Path of a debug variant of a shipped scene (packed once
    per session and set of switches), see fmi_support.debug_variant."""
    import fmi_support

    cache: dict = {}

    def make(model: str, **switches: float) -> Path:
        key = (model, tuple(sorted(switches.items())))
        if key not in cache:
            if not vr.VELARIUM.is_file():
                pytest.skip(f"{vr.VELARIUM} is missing: run `cargo build --release`")
            directory = tmp_path_factory.mktemp(f"debug_{model}")
            cache[key] = fmi_support.debug_variant(model, directory, vr.VELARIUM, **switches)
        return cache[key]

    return make
