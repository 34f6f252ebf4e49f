"""`pip install .` works offline (ctest python.pip_install): a fresh venv that
sees Debian's numpy installs the package from this source tree with
--no-index (nothing downloaded), reusing the configured build folder, and the
installed module imports outside the source tree and draws lines.

    check_pip_install.py SOURCE_DIR BUILD_DIR MESH
"""
import os
import subprocess
import sys
import tempfile
from pathlib import Path

source, build, mesh = (Path(a).resolve() for a in sys.argv[1:4])
with tempfile.TemporaryDirectory(prefix="fabrica-pip-") as tmp:
    venv = Path(tmp) / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    python = venv / "bin" / "python"
    env = dict(os.environ, FABRICA_BUILD_DIR=str(build), PIP_NO_INDEX="1",
               PIP_DISABLE_PIP_VERSION_CHECK="1")
    env.pop("PYTHONPATH", None)
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-index", str(source)],
                   check=True, env=env, cwd=tmp)
    code = (
        "import fabrica, sys\n"
        f"assert fabrica.__file__.startswith({str(venv)!r}), fabrica.__file__\n"
        f"m = fabrica.read_mesh({str(mesh)!r})\n"
        "cam = fabrica.Camera.view(m, 'anterior', width=300, height=300)\n"
        "lines = fabrica.lines(m, cam)\n"
        "assert len(lines) > 0\n"
        "print('installed', fabrica.__file__, len(lines), 'polylines')\n"
    )
    subprocess.run([str(python), "-c", code], check=True, env=env, cwd=tmp)
