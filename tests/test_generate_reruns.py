"""Two `generate` runs in one process (a notebook, a script): the second draws from the problem file as it
is then, never a figure the first drew from an older version of the file."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import gradekit

BANK = Path(__file__).resolve().parents[1] / "problem_bank"


def test_a_second_run_after_editing_the_bank_draws_the_edited_problem(tmp_path):
    bank = tmp_path / "bank"
    bank.mkdir()
    shutil.copy(BANK / "s002_fourbar_120lb.yaml", bank)
    shutil.copy(BANK / "_tolerances.yaml", bank)
    (tmp_path / "hw.yaml").write_text(
        'title: "HW"\ncourse: MEG373\nsalt: "reruns"\nbank: bank\n'
        "problems:\n  - {id: s002-fourbar-120lb, points: 10}\n",
        encoding="utf-8")
    (tmp_path / "roster.csv").write_text("student_id,name\n1001,Ada Lovelace\n", encoding="utf-8")

    def scene(out: str) -> list[str]:
        """The texts of the figure on the student's sheet.html (the sheet's figure, inline)."""
        gradekit.generate(tmp_path / "hw.yaml", tmp_path / "roster.csv", tmp_path / out, jobs=1, keys=False)
        page = (tmp_path / out / "students" / "1001" / "sheet.html").read_text(encoding="utf-8")
        svg = page[page.index("<svg"):page.index("</svg>")]
        return re.findall(r"<tspan[^>]*>([^<]*)</tspan>", svg)

    first = scene("a")
    problem = bank / "s002_fourbar_120lb.yaml"
    problem.write_text(problem.read_text(encoding="utf-8").replace("{name: P, body: rocker",
                                                                   "{name: Q, body: rocker"), encoding="utf-8")
    second = scene("b")
    load = [t for t in first if t.startswith("P = ")]
    assert load and load[0].replace("P = ", "Q = ") in second and not any(t.startswith("P = ") for t in second)
