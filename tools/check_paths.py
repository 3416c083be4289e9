#!/usr/bin/env python3
"""Fails when a comment or doc cites a repository path that is not in the tree.

    python3 tools/check_paths.py [ROOT]

Reads the *.md, *.c, *.h, *.cl, *.cu, *.cuh, *.py, *.sh, meson.build and
pyproject.toml files that git lists (tracked or not ignored; every such file
under ROOT, build folders left out, where git is missing). A cited path is a
token that starts with a top-level folder of the repository (src/, tests/,
bench/, ...), or that names a file with an extension under a folder that
exists (relative to the root, to the citing file or to a folder above it).
It must exist relative to one of those. Left out: tokens with a placeholder
($VAR, *, <...>, {...}, an ALL_CAPS part), absolute paths and URLs, build
folders' paths, programs the build makes (an executable() of the folder's
meson.build), ../ paths that leave the repository's folders (a program's
input in an example), and in bench/results/*/README.md lines marked as history
("at commit", "git show"), whose paths are a past commit's. Prints
FILE:LINE: PATH for each missing path and exits 1 if there is one."""
import os
import re
import subprocess
import sys

SUFFIXES = (".md", ".c", ".h", ".cl", ".cu", ".cuh", ".py", ".sh")
NAMES = ("meson.build", "pyproject.toml")
TOP = ("src", "cl", "cuda", "include", "tests", "bench", "docs", "python", "examples", "tools", ".ci")
# Folders whose paths are made by a build or a run, not kept in the tree.
MADE = re.compile(r"^(build[^/]*|\.device|\.whl|\.study|\.gl|\.git|gpu-out|__pycache__)(/|$)")
TOKEN = re.compile(r"[A-Za-z0-9_.$*{}<>/-]+")
PLACEHOLDER = re.compile(r"[$*{}<>]|\.\.\.|[_-]$|(^|/)[A-Z][A-Z0-9_]*(/|$)")
EXTENSION = re.compile(r"/[^/]*[^/.]\.[A-Za-z][A-Za-z0-9]{0,5}$")
HISTORY = re.compile(r"at commit|git show", re.IGNORECASE)


def files(root):
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z", "-co", "--exclude-standard"],
                             check=True, capture_output=True).stdout.decode()
        names = [n for n in out.split("\0") if n]
    except (OSError, subprocess.CalledProcessError):
        names = []
        for d, dirs, fs in os.walk(root):
            rel = os.path.relpath(d, root)
            dirs[:] = [x for x in dirs if not MADE.match(x)]
            names += [os.path.normpath(os.path.join(rel, f)) for f in fs]
    for n in sorted(names):
        if MADE.match(n) or not os.path.isfile(os.path.join(root, n)):
            continue
        if n.endswith(SUFFIXES) or os.path.basename(n) in NAMES:
            yield n


def bases(root, name):
    """The folders a path in NAME may be relative to: NAME's own and each above it."""
    d = os.path.dirname(name)
    while True:
        yield os.path.join(root, d)
        if not d:
            return
        d = os.path.dirname(d)


def built(base, path):
    """Whether PATH under BASE is a program the build makes: an executable('NAME' of its folder's meson.build."""
    folder, name = os.path.split(os.path.join(base, path))
    try:
        with open(os.path.join(folder, "meson.build"), encoding="utf-8") as f:
            return re.search(r"executable\(\s*'" + re.escape(name) + "'", f.read()) is not None
    except OSError:
        return False


def outside(root, name, path):
    """Whether a ../ path leaves the repository's folders (an example of a program's input, not a citation)."""
    target = os.path.relpath(os.path.normpath(os.path.join(root, os.path.dirname(name), path)), root)
    return target.startswith("..") or not os.path.isdir(os.path.join(root, target.split(os.sep)[0]))


def cited(token):
    """The path TOKEN cites, or None when it cites none."""
    token = token.rstrip(".,:;")
    while token.startswith("./"):
        token = token[2:]
    if "/" not in token or token.startswith("/") or "//" in token or PLACEHOLDER.search(token):
        return None
    if MADE.match(token.lstrip("./")):
        return None
    return token


def check(root):
    missing = []
    for name in files(root):
        history = re.match(r"bench/results/[^/]+/README\.md$", name) is not None
        with open(os.path.join(root, name), encoding="utf-8", errors="replace") as f:
            for number, line in enumerate(f, 1):
                if history and HISTORY.search(line):
                    continue
                for m in TOKEN.finditer(line):
                    # A token glued to a scheme (http:) or a variable ($OUT/...) is no repository path.
                    if m.start() > 0 and line[m.start() - 1] in ":$@\\":
                        continue
                    path = cited(m.group())
                    if path is None:
                        continue
                    first = path.split("/")[0]
                    if first == ".." and outside(root, name, path):
                        continue
                    top = first in TOP or first == ".."
                    here = list(bases(root, name))
                    if not top:
                        # A file under a folder: only where that folder exists.
                        if not EXTENSION.search(path) or not any(os.path.isdir(os.path.join(b, first)) for b in here):
                            continue
                    if not any(os.path.exists(os.path.join(b, path.rstrip("/"))) or built(b, path) for b in here):
                        missing.append(f"{name}:{number}: {path}")
    return missing


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    missing = check(root)
    for m in missing:
        print(m)
    if missing:
        print(f"{len(missing)} cited paths not in the tree", file=sys.stderr)
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
