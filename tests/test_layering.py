"""The numeric core is numpy only: importing every gradekit.mechanics module pulls in no CLI,
YAML, units, plotting or templating library."""

from __future__ import annotations

import json
import subprocess
import sys

FORBIDDEN = ("click", "yaml", "pint", "matplotlib", "jinja2")

PROBE = """
import importlib, json, pkgutil, sys
import gradekit.mechanics as m
for info in pkgutil.walk_packages(m.__path__, m.__name__ + "."):
    importlib.import_module(info.name)
names = sorted(n for n in sys.modules if n.startswith("gradekit.mechanics"))
print(json.dumps({"modules": names, "loaded": sorted({n.split(".")[0] for n in sys.modules})}))
"""


def test_mechanics_imports_no_edge_library():
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True)
    seen = json.loads(out.stdout)
    assert len(seen["modules"]) > 1  # the package and its submodules were imported
    assert [name for name in FORBIDDEN if name in seen["loaded"]] == []
