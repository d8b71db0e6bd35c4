"""StagedFolder.commit: a run's files land in OUT, whole new folders by one rename, files of
folders OUT already has one by one; what the previous run listed and this one did not write goes;
a user's own files stay."""

from __future__ import annotations

from pathlib import Path

import pytest

from gradekit.csvsafe import StagedFolder
from gradekit.errors import GradekitError


def _run(out: Path, files: dict[str, str]) -> list[str]:
    with StagedFolder(out, ".listing") as stage:
        for rel, text in files.items():
            (stage.root / rel).parent.mkdir(parents=True, exist_ok=True)
            (stage.root / rel).write_text(text)
        written = stage.commit("test")
    return sorted(p.relative_to(out).as_posix() for p in written)


def _tree(out: Path) -> dict[str, str]:
    return {p.relative_to(out).as_posix(): p.read_text() for p in sorted(out.rglob("*")) if p.is_file()}


def test_a_new_folder_and_a_known_one(tmp_path):
    out = tmp_path / "out"
    first = {"a.csv": "1", "students/s1/x.pdf": "s1", "students/s2/x.pdf": "s2", "keys/s1.pdf": "k1"}
    assert _run(out, first) == sorted(first)
    (out / "students" / "mine.txt").write_text("the user's")  # never listed: never touched
    second = {"a.csv": "2", "students/s2/x.pdf": "s2'", "students/s3/x.pdf": "s3", "students/s3/deep/y": "y"}
    assert _run(out, second) == sorted(second)
    tree = _tree(out)
    assert {k: v for k, v in tree.items() if not k.startswith(".")} == {**second, "students/mine.txt": "the user's"}
    assert tree[".listing"].splitlines() == ["test", *sorted(second)]
    assert not (out / "students" / "s1").exists() and not (out / "keys").exists()  # emptied folders go
    assert not list(tmp_path.glob(".out.partial-*"))  # the staging folder is gone


def test_a_new_folder_is_told_from_a_sibling_whose_name_it_begins(tmp_path):
    """keys/a is new and moves in whole; keys/ab (a user's folder beside it) is neither inside it nor
    replaced: a path is inside a folder only below a "/" (keys/ab/c is not under keys/a)."""
    out = tmp_path / "out"
    _run(out, {"a.csv": "1", "keys/k.pdf": "k"})
    (out / "keys" / "ab").mkdir()
    (out / "keys" / "ab" / "c").write_text("the user's")
    second = {"a.csv": "2", "keys/k.pdf": "k", "keys/a/b/c": "new", "keys/ab/d": "d"}
    assert _run(out, second) == sorted(second)
    assert {k: _tree(out)[k] for k in second} == second and _tree(out)["keys/ab/c"] == "the user's"
    with pytest.raises(GradekitError, match="keys/ab/c"):  # a file no run listed is never replaced
        _run(out, {"a.csv": "3", "keys/ab/c": "x"})
    assert _tree(out)["keys/ab/c"] == "the user's"
