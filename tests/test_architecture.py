"""The package's layering and API rules (docs/architecture.md), checked on the source.

- imports point downwards only (a package imports nothing from a layer above it);
- other packages import only public names (no ``_module`` or ``_name`` across packages);
- the library never imports the test benches (``benches/``);
- every name of a subpackage's ``__all__`` resolves.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "vfmodel"
LAYERS = ["core", "signals", "fitting", "circuit", "greybox", "detective", "pipeline",
          "report", "cli"]
"""Bottom to top (``errors`` and ``_choices`` sit below ``core``)."""
UPWARD_EXCEPTIONS = {"vfmodel.report.notebook"}
"""Jupyter display hooks (``_repr_html_``, ``_repr_png_``) of results import it lazily."""
PRIVATE_EXCEPTIONS: set[tuple[str, str]] = set()


def _imports() -> list[tuple[str, str, str, list[str]]]:
    out = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        pkg = rel.split("/")[0] if "/" in rel else ""
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module:
                out.append((rel, pkg, node.module, [a.name for a in node.names]))
            elif isinstance(node, ast.Import):
                out += [(rel, pkg, a.name, []) for a in node.names]
    return out


def test_imports_point_downwards() -> None:
    bad = []
    for rel, pkg, module, _ in _imports():
        parts = module.split(".")
        if parts[0] != "vfmodel" or len(parts) < 2 or pkg not in LAYERS or \
                module in UPWARD_EXCEPTIONS:
            continue
        if parts[1] in LAYERS and LAYERS.index(parts[1]) > LAYERS.index(pkg):
            bad.append(f"{rel} imports {module}")
    assert not bad, bad


def test_no_private_names_across_packages() -> None:
    bad = []
    for rel, pkg, module, names in _imports():
        parts = module.split(".")
        if parts[0] != "vfmodel" or len(parts) < 2 or parts[1] == pkg or \
                parts[1] not in LAYERS or (rel, module) in PRIVATE_EXCEPTIONS:
            continue
        if any(p.startswith("_") for p in parts[2:]) or any(n.startswith("_") for n in names):
            bad.append(f"{rel}: from {module} import {', '.join(names)}")
    assert not bad, bad


def test_library_does_not_import_the_benches() -> None:
    bad = [rel for rel, _, module, _ in _imports() if module.split(".")[0] == "benches"]
    assert not bad, bad


@pytest.mark.parametrize("pkg", LAYERS)
def test_every_public_name_resolves(pkg: str) -> None:
    mod = importlib.import_module(f"vfmodel.{pkg}")
    assert mod.__all__, pkg
    submodules = {p.stem for p in (ROOT / pkg).glob("*.py")}
    for name in mod.__all__:
        # a package attribute named like a submodule would be replaced by the module as
        # soon as that is imported
        assert name not in submodules, f"vfmodel.{pkg}.{name} shadows its submodule"
        assert getattr(mod, name) is not None, f"vfmodel.{pkg}.{name}"
