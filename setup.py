"""Package layout for setuptools (the metadata is in pyproject.toml).

The import package ``tt_drake`` is assembled from four folders: ``tt_drake/`` (numpy maths),
``systems/``, ``diagrams/`` and ``models/`` (imported as ``tt_drake.systems``,
``tt_drake.diagrams`` and ``tt_drake.models``). Every package below each folder is found by
discovery, so a new subpackage ships without editing a list.
"""

from setuptools import find_namespace_packages, setup

ROOTS = {"tt_drake": "tt_drake", "tt_drake.systems": "systems",
         "tt_drake.diagrams": "diagrams", "tt_drake.models": "models"}


def packages() -> list[str]:
    found = []
    for name, folder in ROOTS.items():
        found.append(name)
        found += [f"{name}.{sub}" for sub in
                  find_namespace_packages(folder, exclude=["__pycache__", "*.__pycache__"])]
    return sorted(set(found))


setup(package_dir=ROOTS, packages=packages())
