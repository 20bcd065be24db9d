"""The layering of docs/design.md, read from the source with ``ast`` (nothing is imported but in
the last test):

- imports point down the layers: ``tt_drake`` (numpy maths, the shipped data and models) <
  ``tt_drake.systems`` (Drake systems) < ``tt_drake.diagrams`` (builders and runners) <
  ``tt_drake.diagrams.commands`` and ``tt_drake.diagrams.cli`` (the command line);
- imports are at the top of a module, except the few in ``LAZY`` (an optional dependency, or a
  heavy one the command-line parser must not load), each with its reason;
- no module uses another's private names (``from x import _y``, ``x._y``);
- the algorithms in tt_drake/ import no pydrake (fast to test, usable without Drake).
"""

from __future__ import annotations

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import tt_drake

ROOT = Path(__file__).resolve().parent.parent
#: Source folder -> the package it is imported as (setup.py's ROOTS).
FOLDERS = {"tt_drake": "tt_drake", "systems": "tt_drake.systems",
           "diagrams": "tt_drake.diagrams", "models": "tt_drake.models"}
#: Package prefix -> layer, the most specific prefix first; a module may import only its own
#: layer and those below.
LAYERS = (("tt_drake.diagrams.commands", 3), ("tt_drake.diagrams.cli", 3),
          ("tt_drake.diagrams", 2), ("tt_drake.systems", 1), ("tt_drake", 0))

#: The imports left inside a function: (importing module, imported module) -> why.
LAZY = {
    ("tt_drake.diagrams.ray_executor", "ray"): "the optional ray extra",
    # About a second on every import of the predictor, for fitting only.
    ("tt_drake.hitting_point", "sklearn.exceptions"): "heavy, fitting only",
    ("tt_drake.hitting_point", "sklearn.gaussian_process"): "heavy, fitting only",
    ("tt_drake.hitting_point", "sklearn.gaussian_process.kernels"): "heavy, fitting only",
    ("tt_drake.diagrams.commands.rl_baselines", "stable_baselines3"):
        "the optional rl extra",
    ("tt_drake.diagrams.commands.rl_baselines", "stable_baselines3.common.callbacks"):
        "the optional rl extra",
    ("tt_drake.diagrams.commands.rl_baselines", "stable_baselines3.common.vec_env"):
        "the optional rl extra",
    ("tt_drake.diagrams.commands.rl_baselines", "cma"): "the optional gym extra",
    # The commands' parser is built for every command line, --help included: what a command
    # runs (pydrake and the builders) is loaded when it runs.
    ("tt_drake.diagrams.commands.options", "tt_drake.diagrams.scenario"): "pydrake, when run",
    ("tt_drake.diagrams.commands.serve", "tt_drake.diagrams.serve"): "pydrake, when run",
    ("tt_drake.diagrams.commands.rally", "tt_drake.diagrams.rally"): "pydrake, when run",
    ("tt_drake.diagrams.commands.rally", "tt_drake.diagrams.scenario"): "pydrake, when run",
    ("tt_drake.diagrams.commands.bench", "tt_drake.diagrams.bench"): "pydrake, when run",
    ("tt_drake.diagrams.commands.bench", "tt_drake.diagrams.serve"): "pydrake, when run",
    ("tt_drake.diagrams.commands.collect", "tt_drake.diagrams.collect"): "pydrake, when run",
    ("tt_drake.diagrams.commands.collect", "tt_drake.diagrams.inputs"): "pydrake, when run",
    ("tt_drake.diagrams.commands.collect", "tt_drake.diagrams.parallel"): "pydrake, when run",
    ("tt_drake.diagrams.commands.train", "tt_drake.diagrams.train"): "pydrake, when run",
    ("tt_drake.diagrams.commands.train_predictor", "tt_drake.diagrams.scenario"):
        "pydrake, when run",
    ("tt_drake.diagrams.commands.train_predictor", "tt_drake.diagrams.predictor"):
        "pydrake, when run",
    ("tt_drake.diagrams.commands.eval_predictor", "tt_drake.diagrams.predictor"):
        "pydrake, when run",
    ("tt_drake.diagrams.commands.reproduce", "tt_drake.diagrams.reproduce"):
        "pydrake, when run",
}


def _modules() -> dict[str, Path]:
    """Every source module's import name -> its file."""
    found = {}
    for folder, package in FOLDERS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = list(path.relative_to(ROOT / folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join([package, *parts])] = path
    return found


MODULES = _modules()


def _layer(module: str) -> int | None:
    for prefix, layer in LAYERS:
        if module == prefix or module.startswith(prefix + "."):
            return layer
    return None


def _is_package(module: str) -> bool:
    return MODULES[module].name == "__init__.py"


def _imports(module: str, tree: ast.Module):
    """(node, imported module, imported names, at module level) of every import: the names
    ``from m import a, b`` takes (a submodule counts as the module ``m.a``)."""
    def visit(node, top: bool):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import):
                for alias in child.names:
                    yield child, alias.name, (), top
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    package = module if _is_package(module) else module.rpartition(".")[0]
                    for _ in range(child.level - 1):
                        package = package.rpartition(".")[0]
                    base = f"{package}.{base}".rstrip(".")
                for alias in child.names:
                    sub = f"{base}.{alias.name}"
                    if sub in MODULES:
                        yield child, sub, (), top
                    else:
                        yield child, base, (alias.name,), top
            else:
                inner = isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda,
                                           ast.ClassDef))
                yield from visit(child, top and not inner)
    yield from visit(tree, True)


def _trees():
    for module, path in MODULES.items():
        yield module, path, ast.parse(path.read_text(encoding="utf-8"), str(path))


def _project(module: str) -> bool:
    return module == "tt_drake" or module.startswith("tt_drake.")


def test_every_source_folder_is_found():
    assert {"tt_drake.serves", "tt_drake.systems.wam", "tt_drake.diagrams.station",
            "tt_drake.diagrams.cli", "tt_drake.diagrams.commands.options",
            "tt_drake.models"} <= set(MODULES)


def test_imports_point_down_the_layers():
    upward = []
    for module, path, tree in _trees():
        own = _layer(module)
        for node, imported, _, _ in _imports(module, tree):
            if _project(imported) and _layer(imported) > own:
                upward.append(f"{path.relative_to(ROOT)}:{node.lineno}: {module} imports "
                              f"{imported}")
    assert not upward, "an import up the layers:\n" + "\n".join(upward)


def test_imports_are_at_the_top_but_the_listed_lazy_ones():
    inner, used = [], set()
    for module, path, tree in _trees():
        for node, imported, _, top in _imports(module, tree):
            if top:
                continue
            if (module, imported) in LAZY:
                used.add((module, imported))
            else:
                inner.append(f"{path.relative_to(ROOT)}:{node.lineno}: {imported}")
    assert not inner, ("an import inside a function (move it to the top, or list it in LAZY "
                       "with its reason):\n" + "\n".join(inner))
    assert used == set(LAZY), f"LAZY lists imports that are not there: {set(LAZY) - used}"


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _dotted(node: ast.expr) -> str | None:
    """``a.b.c`` of an attribute chain on a name, else None."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return ".".join([node.id, *reversed(parts)])


def _private_definitions(tree: ast.Module) -> set[str]:
    """The private names a module defines: its functions, classes, methods, assigned names and
    attributes (``self._x = ...``), parameters."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
    return {n for n in names if _private(n)}


DEFINED = {module: _private_definitions(ast.parse(path.read_text(encoding="utf-8")))
           for module, path in MODULES.items()}


def _foreign_private_attributes(module: str, tree: ast.Module, where) -> list[str]:
    """``obj._y`` read in ``module`` (``obj`` not ``self`` or ``cls``) where ``_y`` is defined
    only in other project modules: another module's private method or attribute."""
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute) or not _private(node.attr):
            continue
        if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
            continue
        if node.attr in DEFINED[module]:
            continue
        owners = sorted(m for m, names in DEFINED.items() if node.attr in names)
        if owners:
            found.append(f"{where}:{node.lineno}: .{node.attr} (defined in {', '.join(owners)})")
    return found


def test_no_module_uses_another_modules_private_names():
    uses = []
    for module, path, tree in _trees():
        where = path.relative_to(ROOT)
        # The names this module binds to project modules: ``import a.b [as m]``,
        # ``from a import b [as m]`` with b a module.
        bound = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if _project(alias.name):
                        if alias.asname:
                            bound[alias.asname] = alias.name
                        else:
                            bound[alias.name.split(".")[0]] = alias.name.split(".")[0]
        for node, imported, names, _ in _imports(module, tree):
            if not _project(imported) or imported == module:
                continue
            if names and _private(names[0]):
                uses.append(f"{where}:{node.lineno}: from {imported} import {names[0]}")
            if isinstance(node, ast.ImportFrom) and not names:
                alias = next(a for a in node.names if imported.endswith("." + a.name))
                bound[alias.asname or alias.name] = imported
        for node in ast.walk(tree):
            if not isinstance(node, ast.Attribute) or not _private(node.attr):
                continue
            owner = _dotted(node.value)
            if owner is None or owner.split(".")[0] not in bound:
                continue
            head, _, rest = owner.partition(".")
            target = ".".join(filter(None, [bound[head], rest]))
            if target in MODULES and target != module:
                uses.append(f"{where}:{node.lineno}: {target}.{node.attr}")
        uses += _foreign_private_attributes(module, tree, where)
    assert not uses, "a private name of another module:\n" + "\n".join(uses)


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
