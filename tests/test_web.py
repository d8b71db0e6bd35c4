"""`gradekit serve` in a real browser (Debian's chromium driven by Playwright): a student signs in with
their code, is graded at once, uses up attempts and uploads a CSV; another student cannot reach the
first's page; the instructor's downloads are what `gradekit grade` writes from the same answers."""

from __future__ import annotations

import csv
import shutil

import pytest
from test_web_helpers import Server, access_codes, answers_csv, browser, cli, key_rows, make_class

import gradekit


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    folder = make_class(tmp_path_factory.mktemp("web"), "{attempts: 2}")
    cli("serve-passwd", "--manifest", "gen/manifest.json", "--password-stdin", cwd=folder, stdin="correct horse\n")
    return folder


def _values(course, student):
    """(key, right value, wrong value) of each answer: the key's value, and 1.5 times it (outside any tolerance)."""
    return [(r["key"], r["value"], repr(float(r["value"]) * 1.5 + 1.0)) for r in key_rows(course, student)]


def _sign_in(page, url, student, code):
    page.goto(url + "/signin")
    page.fill("#student_id", student)
    page.fill("#code", code)
    page.click("button[type=submit]")


def _row(page, key):
    return page.locator(f'tr[data-key="{key}"]')


def test_a_student_is_graded_at_once_uses_up_attempts_uploads_and_the_instructor_grades_as_the_cli(course):
    codes = access_codes(course)
    (a, a_right, _), (b, _, b_wrong), (c, c_right, _), *_ = _values(course, "1001")
    with Server(course) as server, browser() as chromium:
        page = chromium.new_page()
        _sign_in(page, server.url, "1001", codes["1002"])  # another student's code
        assert "do not match" in page.inner_text(".error")
        _sign_in(page, server.url, "1001", codes["1001"].lower())  # case forgiven
        assert page.url.endswith("/student")
        assert "Ada Lovelace" in page.inner_text("main")
        assert page.locator("#no-feedback").is_visible() and "not graded" not in page.inner_text("main")  # nothing yet
        page.fill(f'input[name="value:{a}"]', a_right)
        page.fill(f'input[name="value:{b}"]', b_wrong)
        page.click("#submit")
        assert _row(page, a).locator(".verdict").inner_text() == "within the tolerance"
        shown = page.inner_text(".feedback")
        assert page.locator("#no-feedback").count() == 0 and "right" in shown
        assert "Problems reading your file" not in shown and "Graded file" not in shown  # typed: no file of theirs
        assert _row(page, b).locator(".verdict").inner_text() == "not within the tolerance"
        assert _row(page, b).locator(".attempts-left").inner_text() == "1 of 2"
        assert key_rows(course, "1001")[1]["value"] not in page.content()  # never the key before the due date
        page.fill(f'input[name="value:{b}"]', b_wrong + "1")  # a second wrong attempt: the last one
        page.click("#submit")
        assert _row(page, b).locator(".attempts-left").inner_text() == "0 of 2"
        assert _row(page, b).locator("input").first.get_attribute("readonly") is not None
        page.screenshot(path=str(course / "student.png"), full_page=True)

        # an upload: shown as read before it counts; b is refused (no attempt left), c graded
        upload = course / "mine.csv"
        upload.write_text(answers_csv(course, "1001", {a: a_right, b: "12", c: c_right}), encoding="utf-8")
        page.set_input_files('input[name="file"]', str(upload))
        page.click("#upload")
        assert c_right in page.inner_text("#read")
        assert "nothing counts yet" in page.inner_text("main").lower()
        page.click("#confirm")
        receipt = page.inner_text("#receipt")
        assert f"{b}: refused (all 2 attempts used)" in receipt and f"{c}: attempt 1 of 2" in receipt
        assert _row(page, c).locator(".verdict").inner_text() == "within the tolerance"
        score = page.inner_text("#score")  # the page's grade of the final answers

        # another student signs in with their own code and sees only their own page
        other = chromium.new_page()
        _sign_in(other, server.url, "1002", codes["1002"])
        text = other.content()
        assert "1002" in text and "Ada Lovelace" not in text and a_right not in text

        # the instructor grades the current answers and downloads the files
        staff = chromium.new_page()
        staff.goto(server.url + "/instructor/signin")
        staff.fill("#password", "correct horse")
        staff.click("button[type=submit]")
        progress = staff.inner_text("#progress")
        assert "1001" in progress and "Bob <b>Tables</b>" in progress  # a name shown as text
        staff.click("#grade")
        files = {}
        for name in ("grades.csv", "canvas.csv", "moodle.csv", "report.md", "attempts.csv"):
            with staff.expect_download() as d:
                staff.click(f'a[href="/instructor/download/{name}"]')
            files[name] = (course / d.value.suggested_filename)
            d.value.save_as(files[name])
        staff.screenshot(path=str(course / "instructor.png"), full_page=True)

    # the same answers as CSV files written here, graded by the command line: the same grades
    subs = course / "subs"
    subs.mkdir()
    (subs / "1001.csv").write_text(answers_csv(course, "1001", {a: a_right, b: b_wrong + "1", c: c_right}),
                                   encoding="utf-8")
    manifest = course / "gen" / "manifest.json"
    gradekit.grade(course / "hw.yaml", course / "roster.csv", subs, course / "cli", manifest=manifest)
    for name in ("grades.csv", "canvas.csv", "moodle.csv"):
        assert files[name].read_bytes() == (course / "cli" / name).read_bytes(), name
    with open(course / "cli" / "grades.csv", newline="", encoding="utf-8") as f:
        row = next(r for r in csv.DictReader(f) if r["student_id"] == "1001")
    assert [float(x) for x in score.split(" / ")] == [float(row["total"]), float(row["max"])]
    # the report and feedback name the graded files: from the page's own answers folder, byte for byte
    exported = course / "gen" / "online-export"
    gradekit.grade(course / "hw.yaml", course / "roster.csv", exported / "submissions", course / "cli2",
                   manifest=manifest)
    assert files["report.md"].read_bytes() == (course / "cli2" / "report.md").read_bytes()
    for fb in (course / "cli2" / "feedback").iterdir():
        assert (exported / "graded" / "feedback" / fb.name).read_bytes() == fb.read_bytes()
    attempts = files["attempts.csv"].read_text(encoding="utf-8")
    assert attempts.count(",graded,") == 4 and attempts.count(",refused,") == 1
    # gradekit export from the command line: the same grades again
    cli("export", "--manifest", "gen/manifest.json", "--out", "exp", cwd=course)
    for name in ("grades.csv", "canvas.csv", "moodle.csv"):
        assert (course / "exp" / "graded" / name).read_bytes() == (course / "cli" / name).read_bytes(), name


@pytest.mark.slow
def test_a_form_is_refused_in_another_session_stored_once_and_kept_through_a_kill(course):
    """CSRF: a token belongs to its session. A form sent twice is stored once. Nothing lost: a server killed
    right after acknowledging a submission has it after a restart."""
    codes = access_codes(course)
    (a, a_right, a_wrong), *_ = _values(course, "1003")
    with browser() as chromium:
        server = Server(course).start()
        try:
            page = chromium.new_page()
            _sign_in(page, server.url, "1003", codes["1003"])
            token = page.locator('input[name="csrf"]').first.get_attribute("value")
            other = chromium.new_context().new_page()  # another browser: its own cookie
            _sign_in(other, server.url, "1002", codes["1002"])
            forged = other.request.post(server.url + "/student/submit",
                                        form={"csrf": token, "form_id": "f1", f"value:{a}": a_wrong})
            assert forged.status == 403 and "Form expired" in forged.text()
            form = {"csrf": token, "form_id": "f2", f"value:{a}": a_wrong, f"unit:{a}": ""}
            first = page.request.post(server.url + "/student/submit", form=form)
            again = page.request.post(server.url + "/student/submit", form=form)
            assert "Submission" in first.text() and "had been sent before" in again.text()
            theirs = other.locator('input[name="csrf"]').first.get_attribute("value")
            taken = other.request.post(server.url + "/student/submit", form={**form, "csrf": theirs})
            assert taken.status == 409 and "Not stored" in taken.text()  # another's form id: nothing stored
            page.fill(f'input[name="value:{a}"]', a_right)
            page.click("#submit")
            assert page.locator("#receipt").get_attribute("data-submission")
            server.stop(kill=True)  # SIGKILL right after the page acknowledged it
            server.start()
            page.goto(server.url + "/student")
            assert page.locator(f'input[name="value:{a}"]').input_value() == a_right
            assert _row(page, a).locator(".attempts-left").inner_text() == "0 of 2"  # f2 once, then the right one
            assert _row(page, a).locator(".verdict").inner_text() == "within the tolerance"
        finally:
            server.stop()


@pytest.mark.slow
def test_after_the_due_date_the_page_is_read_only_shows_the_key_and_refuses_attempts(course, tmp_path):
    codes = access_codes(course)
    closed = course / "closed.yaml"
    closed.write_text((course / "hw.yaml").read_text().replace(
        "online: {attempts: 2}", "online: {attempts: 2, due: 2020-01-01T00:00:00+00:00, late_policy: show-key}"))
    (a, a_right, _), *_ = _values(course, "1002")
    db = tmp_path / "closed.sqlite3"
    with Server(course, "--db", f"sqlite:///{db}", assignment="closed.yaml") as server, browser() as chromium:
        page = chromium.new_page()
        _sign_in(page, server.url, "1002", codes["1002"])
        assert "read-only" in page.inner_text("#closed")
        assert "Correct answer" in page.inner_text(".feedback")  # show-key: the key once the due date is past
        assert page.locator("#submit").count() == 0
        token = page.locator('input[name="csrf"]').first.get_attribute("value")
        r = page.request.post(server.url + "/student/submit",
                              form={"csrf": token, "form_id": "late-1", f"value:{a}": a_right, f"unit:{a}": ""})
        assert r.ok
        page.set_content(r.text())
        assert f"{a}: refused (after the due date)" in page.inner_text("#receipt")
        page.goto(server.url + "/student")
        assert page.locator(f'input[name="value:{a}"]').input_value() == ""  # refused: not the current answer
        # sign-ins are limited: after 5 failures for an account even its right code is not checked
        guesser = chromium.new_page()
        for _ in range(5):
            _sign_in(guesser, server.url, "1003", "AAAAA-AAAAA")
            assert "do not match" in guesser.inner_text(".error")
        _sign_in(guesser, server.url, "1003", codes["1003"])
        assert "Too many failed sign-ins" in guesser.inner_text(".error")
    shutil.rmtree(course / "exp-closed", ignore_errors=True)
    cli("export", "--db", f"sqlite:///{db}", "--out", "exp-closed", cwd=course, check=False)
    # the refused attempt is stored, and counts for nothing
    assert not (course / "exp-closed" / "submissions" / "1002.csv").exists()
