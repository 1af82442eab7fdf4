"""Build hook of `pip install ./python`: the repository root's setup.py (the hook of
`pip install .`) does the work, for the crate one directory up; see that file.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from setuptools import setup

ROOT_HOOK = Path(__file__).resolve().parent.parent / "setup.py"
if not ROOT_HOOK.is_file():
    raise SystemExit(f"velarium: {ROOT_HOOK} is missing: build python/ inside the repository (it bundles the crate "
                     "one directory up), or run `pip install .` at the repository's root")
spec = importlib.util.spec_from_file_location("velarium_wheel_hook", ROOT_HOOK)
hook = importlib.util.module_from_spec(spec)
spec.loader.exec_module(hook)

setup(cmdclass=hook.COMMANDS, distclass=hook.PlatformDistribution)
