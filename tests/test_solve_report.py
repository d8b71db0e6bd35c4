"""What `gradekit solve` prints (round-off of a zero as 0, no line another one already says) and the
figures `gradekit figures` draws of a student's sheet."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner

from gradekit.cli import main


def sections(text: str) -> dict[str, list[tuple[str, str]]]:
    out: dict[str, list[tuple[str, str]]] = {}
    name = ""
    for line in text.splitlines():
        if not line.startswith(" "):
            name = line
        elif "=" in line:
            key, value = (s.strip() for s in line.split("=", 1))
            out.setdefault(name, []).append((key, value.split("  ")[0]))
    return out


def test_solve_prints_round_off_as_zero_and_no_repeated_line() -> None:
    # ch5-ex5-1: a horizontal gas force on a slider crank without gravity: the frame's shaking force has
    # no y component and the shaking moment is zero, which the solver finds to round-off (~1e-15)
    r = CliRunner().invoke(main, ["solve", "ch5-ex5-1"])
    assert r.exit_code == 0, r.output
    lines = dict(sections(r.output)["intermediate:"])
    assert lines["shaking.y"] == "0 N" and lines["shaking_moment"] == "0 N·m"
    assert not re.search(r"\d\.?\d*e-1[3-9]|0\.0{10,}", r.output.split("checks:")[0])
    for name, rows in sections(r.output).items():
        keys = dict(rows)
        assert len(keys) == len(rows), name  # no key twice
        for key in keys:  # a vector's bare name or a force's magnitude at a point repeats its .mag
            assert not (f"{key}.mag" in keys and keys[f"{key}.mag"] == keys[key]), (name, key)
            if "@" in key and key.endswith(".mag"):
                assert key.split("@")[0] + ".mag" not in keys, (name, key)


def test_figures_of_a_students_sheet_come_from_the_assignment(tmp_path: Path) -> None:
    """With --assignment, `figures --student` draws the variant on that student's sheet (the assignment's
    course and salt); without it, values drawn for the course alone, as the note on stderr says."""
    from gradekit import figures
    from gradekit.assignment import sheet_variant

    hw5 = Path(__file__).parents[1] / "examples" / "hw5.yaml"
    runner = CliRunner()
    r = runner.invoke(main, ["figures", "p1", "--student", "1001", "--assignment", str(hw5), "--out",
                             str(tmp_path / "sheet")])
    assert r.exit_code == 0, r.output
    expected = {p.name: p.read_bytes() for p in figures.write_figures(sheet_variant(hw5, "p1", "1001").result,
                                                                         tmp_path / "expected", "svg")}
    assert {p.name: p.read_bytes() for p in (tmp_path / "sheet").iterdir()} == expected
    other = runner.invoke(main, ["figures", "ch5-ex5-1", "--student", "1001", "--out", str(tmp_path / "course")])
    assert other.exit_code == 0 and "not any assignment's sheet" in other.stderr
    assert (tmp_path / "course" / "ch5-ex5-1-scene.svg").read_bytes() != expected["ch5-ex5-1-scene.svg"]
