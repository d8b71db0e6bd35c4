"""The command line: answers, JSON shape, and one-line errors with exit 1 for bad input."""

from __future__ import annotations

import json
import math
import re

from click.testing import CliRunner

from gradekit.cli import main

EX51 = "problem_bank/ch5_ex5_1_slider_crank_static.yaml"


def run(*args):
    return CliRunner().invoke(main, list(args))


def printed(output: str, key: str, unit: str) -> tuple[float, float]:
    """The number printed as 'key = number unit' and half a unit of its last digit."""
    m = re.search(rf"^\s*{re.escape(key)}\s+= (-?\d+(?:\.(\d+))?) {re.escape(unit)}(?:\s|$)", output, re.M)
    assert m, (key, output)
    return float(m.group(1)), 0.5 * 10.0 ** -len(m.group(2) or "")


# Example 5.1 (OB = 30 mm, BC = 70 mm, φ = 45°, P = 40 N): closed form, sin β = r·sin φ / l
BETA = math.asin(30 * math.sin(math.radians(45)) / 70)
EX51_T = -40 * 0.030 * math.sin(math.radians(45) + BETA) / math.cos(BETA)  # N·m
EX51_F03 = 40 * math.tan(BETA)  # N


def test_solve_published_prints_the_answers_correctly_rounded():
    r = run("solve", EX51)
    assert r.exit_code == 0, r.output
    for key, unit, exact in (("T", "N·m", EX51_T), ("F03", "N", EX51_F03)):
        value, half = printed(r.output, key, unit)
        assert half <= 0.005 and abs(value - exact) <= half, (key, value, exact)


def test_solve_json_shape():
    r = run("solve", EX51, "--student", "s001", "--salt", "hw5", "--json")
    assert r.exit_code == 0, r.output
    data = json.loads(r.output)
    assert set(data) >= {"problem", "source", "parameters", "answers", "intermediate", "checks"}
    assert data["problem"] == "ch5-ex5-1"
    assert data["parameters"]["r"] == {"value": 33.0, "unit": "mm"}
    assert data["answers"]["T"]["unit"] == "N*m"
    assert data["checks"]["virtual_work_residual"] < 1e-9
    assert data["checks"]["condition_number"] > 1


def test_bank_list_json():
    r = run("bank", "list", "--json")
    assert r.exit_code == 0, r.output
    rows = json.loads(r.output)
    assert any(row["id"] == "ch5-ex5-1" for row in rows)
    assert {"id", "title", "source"} <= set(rows[0])


def _bad(tmp_path, old, new, name="bad.yaml"):
    text = open(EX51, encoding="utf-8").read()
    assert old in text
    f = tmp_path / name
    f.write_text(text.replace(old, new), encoding="utf-8")
    return str(f)


def test_geometry_that_cannot_assemble_is_one_line_exit_1(tmp_path):
    f = _bad(tmp_path, "value: 70, unit: mm, range: [60, 160]", "value: 10, unit: mm, range: [5, 160]")
    r = run("solve", f)
    assert r.exit_code == 1
    line = r.output.strip()
    assert "\n" not in line and "Traceback" not in r.output
    assert "ch5-ex5-1: cannot be assembled: the rod from A is 10 mm long" in line


def test_misspelt_key_is_reported_with_file_and_line(tmp_path):
    f = _bad(tmp_path, "figure:", "figur:")
    r = run("solve", f)
    assert r.exit_code == 1
    assert f"{f}:" in r.output and ": figur: expected one of" in r.output and "got unknown key 'figur'" in r.output


def test_all_errors_of_a_file_are_reported_together(tmp_path):
    text = open(EX51, encoding="utf-8").read()
    text = text.replace("method: graphical", "method: graphic").replace("type: slider_crank", "type: slidercrank")
    f = tmp_path / "two.yaml"
    f.write_text(text, encoding="utf-8")
    r = run("solve", str(f))
    assert r.exit_code == 1
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert any(":8: method: expected one of analytical, graphical; got 'graphic'" in ln for ln in lines)
    assert any("mechanism.type: expected one of" in ln for ln in lines)


def test_yaml_syntax_error_and_unknown_id(tmp_path):
    f = tmp_path / "broken.yaml"
    f.write_text("id: x\ntitle: [unclosed\n", encoding="utf-8")
    r = run("solve", str(f))
    assert r.exit_code == 1 and "broken.yaml:" in r.output and "expected valid YAML" in r.output
    r = run("solve", "no-such-problem")
    assert r.exit_code == 1 and "expected a bank id" in r.output


def test_expressions_are_never_evaluated_as_python(tmp_path):
    marker = tmp_path / "pwned"
    f = _bad(tmp_path, 'expr: "l >= 2.2*r"', f"expr: \"__import__('os').system('touch {marker}')\"")
    r = run("solve", f)
    assert r.exit_code == 1
    assert not marker.exists()  # the shell command never ran
    assert "constraints.require[0].expr" in r.output


def test_usage_error_is_exit_2():
    r = run("solve", EX51, "--student", "a", "--seed", "3")
    assert r.exit_code == 2


def test_load_points_use_the_printed_names(tmp_path):
    # Example 5.1 prints O2, A, B as O, B, C: a load at C is on the piston pin, O2 is refused
    f = _bad(tmp_path, "{name: P, body: slider, magnitude: P, angle: 180}",
             "{name: P, body: slider, at: C, magnitude: P, angle: 180}")
    r = run("solve", f)
    assert r.exit_code == 0, r.output
    value, half = printed(r.output, "T", "N·m")
    assert abs(value - EX51_T) <= half
    f = _bad(tmp_path, "{name: P, body: slider, magnitude: P, angle: 180}",
             "{name: P, body: slider, at: O2, magnitude: P, angle: 180}", "b2.yaml")
    r = run("solve", f)
    assert r.exit_code == 1
    assert (
        "loads[0].at: expected a point as printed in this problem (B, C, O); got 'O2', which is printed as 'O'"
        in r.output
    )


def test_generate_prints_its_own_messages_only(tmp_path):
    """A fresh process, as an instructor runs it: the summary line on stderr, no library's INFO
    chatter (pikepdf announces its logger bridge at INFO)."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    roster = tmp_path / "roster.csv"
    roster.write_text("student_id,name\n1001,Ana Pérez\n", encoding="utf-8")
    out = subprocess.run(
        [sys.executable, "-m", "gradekit", "generate", str(root / "examples" / "hw5.yaml"), "--roster", str(roster),
         "--out", str(tmp_path / "out"), "--no-keys"],
        capture_output=True, text=True, cwd=tmp_path, check=True)
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("wrote documents for 1 student(s)"), out.stderr
