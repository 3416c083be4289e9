"""The layers are boundaries the build enforces. With the include path each
target is compiled with (the build's compile_commands.json), a header of a
library layer's own or a lower layer compiles and one of a layer above does
not, by its bare name or by a path through src/; the program sees petblur.h and
its own folders only; no include climbs out with ../; kernels (cl/, cuda/) include nothing from src/. So a
widened path in a meson.build fails here, and an include that reaches up fails
the build itself.

usage: test_layers.py ROOT BUILD_DIR
"""
import functools
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile
import unittest

ROOT = BUILD = None
# One header of each library layer, bottom up.
HEADERS = [("core", "error.h"), ("motion", "motion.h"), ("paths", "path.h"), ("devices", "backend.h"),
           ("api", "objects.h"), ("estimate", "estimate.h")]
ORDER = [name for name, _ in HEADERS]


@functools.lru_cache(maxsize=None)
def flags_of(folder):
    """The compiler and its include flags for a source file in src/FOLDER
    (read once a folder: every probe of it compiles with the same)."""
    with open(os.path.join(BUILD, "compile_commands.json")) as f:
        commands = json.load(f)
    want = os.path.join(os.path.realpath(ROOT), "src", folder) + os.sep
    for c in commands:
        path = os.path.realpath(os.path.join(c["directory"], c["file"]))
        if path.startswith(want) and path.endswith(".c"):
            args = c.get("arguments") or shlex.split(c["command"])
            keep, i = [args[0]], 1
            while i < len(args):
                if args[i] in ("-I", "-isystem", "-include"):
                    keep += args[i:i + 2]
                    i += 2
                    continue
                if args[i].startswith(("-I", "-D", "-std")):
                    keep.append(args[i])
                i += 1
            return tuple(keep), c["directory"]
    raise AssertionError(f"no source of src/{folder} in compile_commands.json")


def found(folder, header):
    """Whether `#include "header"` reaches petblur's own file (a system header
    of the same name, such as glibc's error.h, does not count) with the flags a
    file of src/FOLDER is compiled with."""
    args, cwd = flags_of(folder)
    with tempfile.TemporaryDirectory() as d:
        src = os.path.join(d, "probe.c")
        with open(src, "w") as f:
            f.write(f'#include "{header}"\n')
        p = subprocess.run([*args, "-M", src], capture_output=True, text=True, cwd=cwd)
        deps = p.stdout.replace("\\\n", " ").split()
        mine = tuple(os.path.join(os.path.realpath(ROOT), f) + os.sep for f in ("src", "include"))
        ours = [x for x in deps if os.path.basename(x) == os.path.basename(header) and
                os.path.realpath(os.path.join(cwd, x)).startswith(mine)]
        return p.returncode == 0 and bool(ours)


class Layers(unittest.TestCase):
    def test_each_layer_sees_itself_and_below_only(self):
        for layer in ORDER:
            for owner, header in HEADERS:
                below = ORDER.index(owner) <= ORDER.index(layer)
                self.assertEqual(found(layer, header), below,
                                 f"src/{layer} {'cannot' if below else 'can'} include {owner}'s {header}")
                for qualified in (f"{owner}/{header}", f"src/{owner}/{header}"):
                    self.assertFalse(found(layer, qualified) and not below,
                                     f"src/{layer} reaches {owner} through {qualified}")

    def test_program_sees_only_the_public_header(self):
        self.assertTrue(found("cli", "petblur.h"))
        for owner, header in HEADERS:
            for name in (header, f"{owner}/{header}", f"src/{owner}/{header}"):
                self.assertFalse(found("cli", name), f"the program includes {name}")

    def test_no_include_climbs_out_of_its_folder(self):
        """`#include "../api/objects.h"` would pass any include path."""
        for folder, _, names in os.walk(os.path.join(ROOT, "src")):
            for name in names:
                if name.endswith((".c", ".h")):
                    with open(os.path.join(folder, name), errors="replace") as f:
                        for n, line in enumerate(f, 1):
                            self.assertNotRegex(line, r'^\s*#\s*include\s*"[^"]*\.\./',
                                                f"{os.path.relpath(folder, ROOT)}/{name}:{n}")

    def test_kernels_include_only_kernels(self):
        for folder in ("cl", "cuda"):
            base = os.path.join(ROOT, folder)
            for name in sorted(os.listdir(base)):
                with open(os.path.join(base, name), errors="replace") as f:
                    for n, line in enumerate(f, 1):
                        m = re.match(r'\s*#\s*include\s*"([^"]+)"', line)
                        if not m:
                            continue
                        target = os.path.normpath(os.path.join(base, m.group(1)))
                        where = os.path.relpath(target, ROOT).split(os.sep)[0]
                        self.assertIn(where, ("cl", "cuda"), f"{folder}/{name}:{n} includes {m.group(1)}")
                        self.assertTrue(os.path.exists(target), f"{folder}/{name}:{n}: {m.group(1)} is missing")


if __name__ == "__main__":
    ROOT, BUILD = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    unittest.main(argv=sys.argv[:1], verbosity=2)
