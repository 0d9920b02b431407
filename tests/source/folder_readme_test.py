#!/usr/bin/env python3
"""Every library folder's README lists every file in it: a newcomer finds each file's purpose
where the folder begins. For each folder below, every tracked file under it (its sources,
private and public headers; not tests) must be named in its README.md as `name` (its file
name, or its path from the folder). Prints what is missing and exits 1 if anything is."""
import subprocess
import sys
from pathlib import Path

# folder: the folders whose files its README lists (besides itself)
FOLDERS = {
    "core": [],
    "view": [],
    "storage": [],
    "protocol": [],
    "renderer": [],
    "server": [],
    "lod/mt": ["lod/include/tetrascope/lod/mt"],
    "lod/cut": ["lod/include/tetrascope/lod/cut"],
    "lod/simplify": ["lod/include/tetrascope/lod/simplify"],
    "lod/field": ["lod/include/tetrascope/lod/field"],
}
LISTED = (".cpp", ".h", ".txt", ".yaml", ".json", ".js", ".mjs")


def tracked(root):
    try:
        return subprocess.run(["git", "-C", str(root), "ls-files"], capture_output=True, text=True, check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        return [str(p.relative_to(root)) for p in root.rglob("*") if p.is_file() and ".git" not in p.parts and "build" not in p.parts]


def main():
    root = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    files = tracked(root)
    missing = []
    checked = 0
    for folder, also in FOLDERS.items():
        readme = root / folder / "README.md"
        if not readme.is_file():
            missing.append(f"{folder}/README.md: missing")
            continue
        text = readme.read_text()
        for base in [folder] + also:
            for f in files:
                if not f.startswith(base + "/") or not f.endswith(LISTED) or "/testdata/" in f or "/schema/" in f:
                    continue
                checked += 1
                name, relative = Path(f).name, f[len(folder) + 1:]
                if f"`{name}`" not in text and f"`{relative}`" not in text and f"{name}`" not in text:
                    missing.append(f"{folder}/README.md does not list {f}")
    for m in missing:
        print(m)
    print(f"folder readmes: {len(missing)} files unlisted of {checked} in {len(FOLDERS)} folders")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
