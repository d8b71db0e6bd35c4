"""`gradekit serve` on PostgreSQL (a throwaway cluster started here): two server processes share one
database, a student's attempts count across both, and `gradekit export --db URL` grades as `gradekit grade`."""

from __future__ import annotations

import re

import httpx
import pytest
from test_web_helpers import Server, access_codes, answers_csv, cli, key_rows, make_class, postgres_cluster

pytestmark = pytest.mark.slow


def _csrf(html: str) -> str:
    return re.search(r'name="csrf" value="([^"]+)"', html).group(1)


def _sign_in(client: httpx.Client, student: str, code: str) -> str:
    page = client.get("/signin").text
    r = client.post("/signin", data={"csrf": _csrf(page), "student_id": student, "code": code},
                    follow_redirects=True)
    assert r.status_code == 200 and r.url.path == "/student", r.text
    return r.text


def _attempts_left(html: str, key: str) -> str:
    row = re.search(rf'<tr[^>]*data-key="{re.escape(key)}">(.*?)</tr>', html, re.S).group(1)
    return re.search(r'class="num attempts-left">([^<]*)<', row).group(1).strip()


def test_two_servers_share_one_postgresql_and_export_grades_as_the_cli(tmp_path):
    course = make_class(tmp_path / "pg", "{attempts: 3}")
    codes = access_codes(course)
    (a, a_right, a_wrong), (b, b_right, _), *_ = [
        (r["key"], r["value"], repr(float(r["value"]) * 1.5 + 1.0)) for r in key_rows(course, "1002")]
    with postgres_cluster() as url:
        cli("serve-passwd", "--db", url, "--password-stdin", cwd=course, stdin="correct horse\n")
        with Server(course, "--db", url) as one, Server(course, "--db", url) as two:
            with httpx.Client(base_url=one.url) as c1, httpx.Client(base_url=two.url) as c2:
                page = _sign_in(c1, "1002", codes["1002"])
                r = c1.post("/student/submit", data={"csrf": _csrf(page), "form_id": "pg-1", f"value:{a}": a_wrong,
                                                     f"unit:{a}": ""})
                assert "Submission" in r.text and _attempts_left(r.text, a) == "2 of 3"
                # the same session cookie works on the other process (the secret beside the manifest)
                c2.cookies.update(c1.cookies)
                page = c2.get("/student").text
                assert _attempts_left(page, a) == "2 of 3"
                r = c2.post("/student/submit", data={"csrf": _csrf(page), "form_id": "pg-2", f"value:{a}": a_right,
                                                     f"unit:{a}": "", f"value:{b}": b_right, f"unit:{b}": ""})
                assert _attempts_left(r.text, a) == "1 of 3" and _attempts_left(r.text, b) == "2 of 3"
                # the first form sent again to the other process: stored once
                again = c2.post("/student/submit", data={"csrf": _csrf(page), "form_id": "pg-1",
                                                         f"value:{a}": a_wrong, f"unit:{a}": ""})
                assert "had been sent before" in again.text and _attempts_left(again.text, a) == "1 of 3"
        cli("export", "--db", url, "--out", "exp", cwd=course)
    subs = course / "subs"
    subs.mkdir()
    (subs / "1002.csv").write_text(answers_csv(course, "1002", {a: a_right, b: b_right}), encoding="utf-8")
    cli("grade", "hw.yaml", "--roster", "roster.csv", "--submissions", "subs", "--out", "cli", "--manifest",
        "gen/manifest.json", cwd=course)
    for name in ("grades.csv", "canvas.csv", "moodle.csv"):
        assert (course / "exp" / "graded" / name).read_bytes() == (course / "cli" / name).read_bytes(), name
    attempts = (course / "exp" / "attempts.csv").read_text(encoding="utf-8")
    assert attempts.count(",graded,") == 3
