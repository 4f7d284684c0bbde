"""`vo/` never imports mujoco, directly or indirectly: estimators read datasets like real recordings."""
import subprocess
import sys


def test_no_vo_module_imports_mujoco():
    code = (
        "import pkgutil, importlib, sys, vo\n"
        "mods = [m.name for m in pkgutil.walk_packages(vo.__path__, 'vo.')]\n"
        "for m in mods: importlib.import_module(m)\n"
        "print(len(mods), 'mujoco' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert int(out[0]) > 30 and out[1] == "False"
