"""The extension's own modules, read as source: Blender runs them without the package on
its path (the extension carries it as its submodule ``.motionclean``)."""

from __future__ import annotations

import ast

from helpers import ROOT


def test_the_extension_imports_the_package_it_carries_not_an_installed_one():
    """``from motionclean... import`` resolves only where motionclean is installed beside
    Blender (this project's environments, whose session imports it first): in an
    animator's Blender the extension failed to enable ("No module named 'motionclean'",
    panels.py). Every import of the package is relative, of the copy in the zip."""
    absolute = []
    for path in sorted((ROOT / "blender").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = []
            if isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module or ""]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            absolute += [
                f"{path.name}:{node.lineno}"
                for name in names
                if name == "motionclean" or name.startswith("motionclean.")
            ]
    assert absolute == []
