"""Build the Blender extension zip: ``blender/`` plus the motionclean package as its module.

    python scripts/build_blender_extension.py [OUT_DIR]     # `make blender`; default dist/

Writes ``OUT_DIR/motionclean-blender-VERSION.zip`` with ``blender_manifest.toml`` and the
extension's modules at its root and the package in ``motionclean/`` (without ``cli/``: the
extension never imports click). The manifest's version must be the package's. Prints the
zip's path.
"""

from __future__ import annotations

import sys
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXTENSION = ROOT / "blender"
PACKAGE = ROOT / "motionclean"
#: Parts of the package the extension leaves out.
LEFT_OUT = ("cli",)


def package_version() -> str:
    namespace: dict[str, str] = {}
    exec((PACKAGE / "core" / "version.py").read_text(), namespace)
    return namespace["__version__"]


def build(out_dir: Path) -> Path:
    manifest = tomllib.loads((EXTENSION / "blender_manifest.toml").read_text())
    version = package_version()
    if manifest["version"] != version:
        raise SystemExit(
            f"blender/blender_manifest.toml: version {manifest['version']} is not the "
            f"package's {version}"
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / f"motionclean-blender-{version}.zip"
    files = [(path, path.relative_to(EXTENSION)) for path in sorted(EXTENSION.glob("*"))]
    files += [
        (path, Path("motionclean") / path.relative_to(PACKAGE))
        for path in sorted(PACKAGE.rglob("*.py"))
        if path.relative_to(PACKAGE).parts[0] not in LEFT_OUT
    ]
    files.append((ROOT / "LICENSE", Path("LICENSE")))
    partial = target.with_suffix(".zip.tmp")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as archive:
        for path, name in files:
            if path.is_file() and "__pycache__" not in path.parts:
                archive.write(path, name.as_posix())
    partial.replace(target)
    return target


if __name__ == "__main__":
    print(build(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "dist"))
