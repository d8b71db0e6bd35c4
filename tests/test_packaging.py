"""What `pip install .` (the README's first command) puts in the wheel: every package of the source tree.

An editable install (what CI and the test runs use) finds any subpackage on disk, so a package left
out of pyproject.toml's list fails only for a user who installs normally, at their first command.
"""

from __future__ import annotations

from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib", reason="Python 3.11's TOML reader")

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_of_the_source_tree_is_in_the_wheel():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    listed = set(config["packages"])
    on_disk = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "gradekit").rglob("__init__.py")}
    assert on_disk - listed == set()
    for name, folder in config["package-dir"].items():  # the bank and the templates, from the checkout's top
        assert name in listed and (ROOT / folder).is_dir()



def test_the_program_is_the_command_line_s_entry_point():
    import gradekit.cli

    entry = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["scripts"]["gradekit"]
    module, _, name = entry.partition(":")
    assert module == "gradekit.cli" and callable(getattr(gradekit.cli, name))
