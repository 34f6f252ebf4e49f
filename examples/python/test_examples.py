"""The Python examples run (through ctest, label python) and make their files."""
import os
import runpy
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent


@pytest.fixture
def liver():
    root = os.environ.get("FABRICA_TEST_MESHES")
    if not root:
        pytest.skip("FABRICA_TEST_MESHES not set (run through ctest)")
    return str(Path(root) / "meshes" / "anatomy" / "liver" / "sofa_liver_coarse.obj")


def run_example(name, *args):
    saved = sys.argv
    sys.argv = [name, *args]
    try:
        runpy.run_path(str(HERE / name), run_name="__main__")
    finally:
        sys.argv = saved


def test_lines_svg(tmp_path, liver):
    out = tmp_path / "out.svg"
    run_example("lines_svg.py", liver, str(out))
    text = out.read_text()
    assert text.startswith("<?xml") or text.startswith("<svg")
    assert "<path" in text


def test_figure(tmp_path, liver):
    out = tmp_path / "figure.png"
    run_example("figure.py", liver, str(out))
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.stat().st_size > 10000
