"""The layering of docs/design.md: the algorithms in tt_drake/ import no pydrake (fast to test,
usable outside Drake); only tt_drake.systems and tt_drake.diagrams may."""

import pkgutil
import subprocess
import sys
from pathlib import Path

import tt_drake


def test_tt_drake_modules_do_not_import_pydrake():
    folder = Path(tt_drake.__file__).parent
    modules = [f"tt_drake.{m.name}" for m in pkgutil.iter_modules([str(folder)])
               if m.name not in ("systems", "diagrams", "models")]
    modules += [f"tt_drake.modelgen.{m.name}"
                for m in pkgutil.iter_modules([str(folder / "modelgen")])]
    assert len(modules) > 20
    code = ("import importlib, sys\n"
            f"for m in {modules!r}: importlib.import_module(m)\n"
            "print(sorted(k for k in sys.modules if k.split('.')[0] == 'pydrake'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]", f"pydrake imported by a tt_drake module: {out}"
