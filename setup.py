"""pip install . — builds the fabrica Python module with the project's CMake.

Offline and without extra build tools: setuptools (Debian: python3-setuptools)
runs CMake on this source tree and copies the compiled module next to the
pure-Python package (python/fabrica/). Needs the same Debian packages as the
C++ build (scripts/setup) plus python3-dev, pybind11-dev and python3-numpy.

    pip install .                         # in a venv: python3 -m venv --system-site-packages
    FABRICA_BUILD_DIR=build pip install . # reuse an existing, configured build folder
    FABRICA_CMAKE_ARGS="-DFABRICA_NATIVE=ON" pip install .

Debian marks its Python as externally managed: install into a venv (with
--system-site-packages, so Debian's numpy is seen), or pass
--break-system-packages at your own risk. See docs/python.md.
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"project\(fabrica VERSION ([0-9.]+)", text)
    return match.group(1) if match else "0.0.0"


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = os.environ.get("FABRICA_BUILD_DIR")
        if build_dir:
            build_dir = Path(build_dir).resolve()
        else:
            build_dir = Path(self.build_temp).resolve() / "cmake"
        if not (build_dir / "CMakeCache.txt").exists():
            args = [
                "cmake", "-S", str(ROOT), "-B", str(build_dir),
                "-DCMAKE_BUILD_TYPE=Release",
                "-DFABRICA_WITH_PYTHON=ON",
                "-DFABRICA_BUILD_TESTS=OFF",
                "-DFABRICA_BUILD_BENCH=OFF",
                f"-DPython3_EXECUTABLE={sys.executable}",
            ]
            if shutil.which("ninja"):
                args += ["-G", "Ninja"]
            args += shlex.split(os.environ.get("FABRICA_CMAKE_ARGS", ""))
            subprocess.run(args, check=True)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 2))
        subprocess.run(
            ["cmake", "--build", str(build_dir), "--target", "fabrica_python", "-j", jobs],
            check=True,
        )
        built = sorted((build_dir / "python" / "fabrica").glob("_fabrica*.so"))
        if not built:
            raise RuntimeError(f"fabrica: the build made no module in {build_dir}/python/fabrica")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[-1], target)


setup(
    name="fabrica",
    version=project_version(),
    description="Feature lines, hatching and focus-and-context illustrations of anatomy meshes",
    packages=["fabrica"],
    package_dir={"": "python"},
    package_data={"fabrica": ["__init__.pyi", "py.typed"]},
    ext_modules=[Extension("fabrica._fabrica", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    python_requires=">=3.9",
    install_requires=["numpy"],
    zip_safe=False,
)
