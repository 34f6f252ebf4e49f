"""Shared fixtures: the bundled meshes and the built `fabrica` executable
(ctest passes FABRICA_EXE, FABRICA_TEST_MESHES and PYTHONPATH)."""
import os
import subprocess
from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def meshes():
    root = os.environ.get("FABRICA_TEST_MESHES")
    if not root:
        pytest.skip("FABRICA_TEST_MESHES not set (run through ctest)")
    return Path(root) / "meshes"


@pytest.fixture(scope="session")
def liver(meshes):
    return meshes / "anatomy" / "liver" / "sofa_liver_coarse.obj"


@pytest.fixture(scope="session")
def fabrica_cli():
    exe = os.environ.get("FABRICA_EXE")
    if not exe:
        pytest.skip("FABRICA_EXE not set (run through ctest)")

    def run(*args, check=True):
        result = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
        if check and result.returncode != 0:
            raise AssertionError(f"fabrica {' '.join(map(str, args))}: {result.stderr}")
        return result

    return run
