"""The command line: parse options, call one function per command. Only this module imports click."""

from __future__ import annotations

import gc
import json
import logging
import sys
from pathlib import Path

import click

from gradekit import __version__
from gradekit.errors import GradekitError

log = logging.getLogger("gradekit")


class _Group(click.Group):
    """The command group: Ctrl-C ends any command with exit 130 (128 + SIGINT) and one line; the command
    list shows each command's first sentence whole (wrapped), never cut with "..."."""

    group_class = type  # subgroups (bank) list their commands the same way

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = [(name, cmd.get_short_help_str(limit=10_000)) for name in self.list_commands(ctx)
                if (cmd := self.get_command(ctx, name)) is not None and not cmd.hidden]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            click.echo("interrupted (Ctrl-C)", err=True)
            raise click.exceptions.Exit(130) from None


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="gradekit")
@click.option("-v", "--verbose", count=True, help="More output.")
@click.option("-q", "--quiet", is_flag=True, help="Only errors.")
def main(verbose: int, quiet: bool) -> None:
    """gradekit: individual-value force-analysis assignments, keys and grading (MEG373)."""
    level = logging.ERROR if quiet else logging.DEBUG if verbose else logging.INFO
    # gradekit's own messages at *level*; other libraries' only when they warn (pikepdf, for one,
    # announces its logger at INFO)
    others = logging.DEBUG if verbose > 1 else logging.WARNING
    logging.basicConfig(level=others, format="%(message)s", stream=sys.stderr)
    log.setLevel(level)


def run() -> None:
    """The ``gradekit`` program (and ``python -m gradekit``): `main` in a process of its own."""
    # Each command is a batch job whose records (for grade, a class's key entries, answers and
    # verdicts: hundreds of thousands) live until it ends. At CPython's default, a collection every
    # 700 allocations, the cyclic collector walks them again and again: about a sixth of grade's CPU
    # (benchmarks/RESULTS.md). The process's owner sets this, as mypy's does; a library call never does.
    gc.set_threshold(100_000, 50, 100)
    main()


def _variant(problem, published: bool, student: str | None, seed: int | None, course: str, salt: str, redraw: int = 0):
    from gradekit.solving.sampling import variant

    if sum(x is not None and x is not False for x in (student, seed)) + bool(published) > 1:
        raise click.UsageError("give at most one of --published, --student and --seed")
    if redraw and student is None:
        raise click.UsageError("--redraw goes with --student")
    return variant(problem, course=course, salt=salt, student=student, seed=seed, redraw=redraw)


def _assignment_opts(f):
    f = click.option("--manifest", type=click.Path(dir_okay=False, exists=True), default=None,
                     help="The manifest.json of generate: the student's re-draws as printed.")(f)
    return click.option("--assignment", type=click.Path(dir_okay=False, exists=True), default=None,
                        help="With --student: the values on that student's sheet of this assignment "
                        "(its course and salt).")(f)


def _not_a_sheet(course: str, salt: str) -> str:
    return (f"values drawn for course {course!r}, salt {salt!r}, not any assignment's sheet; "
            "give --assignment FILE for the student's sheet")


def _student_variant(problem, published, student, seed, course, salt, redraw, bank, assignment, manifest,
                     quiet=False):
    """The variant to show: a student's sheet of --assignment, or values drawn from course and salt."""
    from gradekit.bank.registry import resolve

    if assignment is None:
        if manifest is not None:
            raise click.UsageError("--manifest goes with --assignment")
        if student is not None and not quiet:
            click.echo(f"note: {_not_a_sheet(course, salt)}", err=True)
        return _variant(resolve(problem, bank), published, student, seed, course, salt, redraw)
    if student is None or published or seed is not None or redraw:
        raise click.UsageError("--assignment goes with --student only (course, salt and re-draws come from it)")
    from gradekit.assignment import sheet_variant

    return sheet_variant(assignment, problem, student, manifest, bank)


_bank_opt = click.option(
    "--bank",
    type=click.Path(file_okay=False),
    default=None,
    help="Problem bank folder (default: the bundled problem_bank).",
)


@main.command()
@click.argument("problem")
@click.option("--published", is_flag=True, help="The values printed in the source (default).")
@click.option("--student", default=None, help="That student's individual values.")
@click.option("--seed", type=int, default=None, help="Values drawn from this seed.")
@click.option("--course", default="MEG373", show_default=True, help="Course name (part of the seed).")
@click.option("--salt", default="", help="Assignment salt (part of the seed).")
@click.option(
    "--redraw",
    type=click.IntRange(0, 1000),
    default=0,
    help="That student's n-th re-draw (as recorded under redraws: in an assignment).",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@_bank_opt
@_assignment_opts
def solve(
    problem: str,
    published: bool,
    student: str | None,
    redraw: int,
    seed: int | None,
    course: str,
    salt: str,
    as_json: bool,
    bank: str | None,
    assignment: str | None,
    manifest: str | None,
) -> None:
    """Solve PROBLEM (a bank id or a YAML path) and print parameters, intermediate values and answers."""
    from gradekit.solving import report

    v = _student_variant(problem, published, student, seed, course, salt, redraw, bank, assignment, manifest,
                         quiet=as_json)
    if as_json:
        data = report.as_json(v.result)
        if student is not None and assignment is None:
            data["note"] = _not_a_sheet(course, salt)
        click.echo(json.dumps(data, indent=2))
    else:
        click.echo(report.as_text(v.result))


@main.group()
def bank() -> None:
    """List, show and stress-test the problem bank."""


@bank.command("list")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list.")
@_bank_opt
def bank_list(as_json: bool, bank: str | None) -> None:
    """List the bank's problems."""
    from gradekit.bank.registry import load_bank

    rows = [
        {
            "id": p.id,
            "title": p.title,
            "source": p.source,
            "mechanism": p.kind,
            "method": p.method,
            "analysis": p.analysis,
            "tags": list(p.tags),
            "answers": [a.key for a in p.answers],
            "random_parameters": [n for n, q in p.parameters.items() if q.random],
        }
        for p in load_bank(bank).values()
    ]
    if as_json:
        click.echo(json.dumps(rows, indent=2))
        return
    for r in rows:
        click.echo(f"{r['id']:<34} {r['mechanism']:<20} {r['analysis']:<8} {r['method']:<10} {r['title']}")


@bank.command("show")
@click.argument("problem")
@click.option("--student", default=None, help="Render that student's variant.")
@click.option("--course", default="MEG373", show_default=True, help="Course name (part of the seed).")
@click.option("--salt", default="", help="Assignment salt (part of the seed).")
@_bank_opt
@_assignment_opts
def bank_show(problem: str, student: str | None, course: str, salt: str, bank: str | None,
              assignment: str | None, manifest: str | None) -> None:
    """Show a problem's statement with the published or a student's values, and its answers."""
    from gradekit.solving import report
    from gradekit.statement import render_statement

    v = _student_variant(problem, False, student, None, course, salt, 0, bank, assignment, manifest)
    click.echo(render_statement(v.problem, v.result.values))
    click.echo()
    click.echo(report.as_text(v.result))


@bank.command("new")
@click.argument("kind")
def bank_new(kind: str) -> None:
    """Print a commented starter problem for mechanism KIND (save it, edit it, then bank check it)."""
    from gradekit.bank.starter import starter
    from gradekit.mechanics.mechanisms import KINDS

    if kind not in KINDS:
        import difflib

        near = difflib.get_close_matches(kind, list(KINDS), n=1, cutoff=0.5)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        raise click.UsageError(f"expected a mechanism kind among {', '.join(KINDS)}; got {kind!r}{hint}")
    click.echo(starter(kind), nl=False)


@bank.command("check")
@click.argument("ids", nargs=-1)
@click.option(
    "--variants", type=click.IntRange(1, 100000), default=100, show_default=True, help="Variants drawn per problem."
)
@click.option(
    "--class-size",
    type=click.IntRange(1, 100000),
    default=300,
    show_default=True,
    help="Class size for the distinct-variant count.",
)
@_bank_opt
def bank_check(ids: tuple[str, ...], variants: int, class_size: int, bank: str | None) -> None:
    """Stress-test problems (bank ids or YAML paths, as for solve): every variant assembles, solves, checks
    and grades its own key."""
    from gradekit.bank.registry import resolve
    from gradekit.bankcheck import check_bank, check_problem

    paths = [i for i in ids if i.endswith((".yaml", ".yml")) or Path(i).is_file()]
    named = [i for i in ids if i not in paths]
    ok = all([check_problem(resolve(p, bank), variants, class_size, click.echo) for p in paths])
    if named or not paths:
        ok &= check_bank(named, variants, class_size, bank, echo=click.echo)
    else:
        click.echo("bank check: " + ("all problems passed" if ok else "FAILED"))
    if not ok:
        sys.exit(1)


@main.command()
@click.argument("assignment", type=click.Path(exists=True, dir_okay=False))
@click.option("--roster", required=True, type=click.Path(exists=True, dir_okay=False), help="Class roster CSV.")
@click.option("--submissions", required=True, type=click.Path(),
              help="Folder of submitted CSVs, or the zip an LMS's 'download all submissions' gives.")
@click.option("--out", required=True, type=click.Path(file_okay=False), help="Output folder.")
@click.option(
    "--manifest",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    help="manifest.json written by generate: grade against the keys it froze (keys.json) and report what changed.",
)
@click.option("--reveal", is_flag=True, help="Show the correct values in the students' feedback.")
@click.option(
    "--recompute-keys",
    is_flag=True,
    help="With --manifest: grade against keys recomputed from the current bank, not the keys frozen at generation.",
)
@click.option(
    "--carry-forward",
    is_flag=True,
    help="Credit a later answer that is right from the student's own wrong earlier ones (error carried forward), "
    "on every problem the assignment does not set carry_forward: false.",
)
@click.option("--exports", default=None, metavar="NAMES",
              help="Comma-separated outputs to write, over the assignment's exports: list: grades, canvas, moodle, "
              "feedback, report, hand, histogram (the default set), moodle-feedback-zip, canvas-feedback-zip.")
@click.option("--hand", type=click.Path(exists=True, dir_okay=False), default=None,
              help="A hand.csv with its points column filled: the points you gave the answers checked by hand "
                   "(default: OUT/hand.csv of an earlier run, filled in place).")
@click.option("--strict", is_flag=True,
              help="Exit 1 when anything needs attention: an unreadable file or answer, a file tied to no student, "
                   "a file naming another student inside (the outputs are still written).")
@_bank_opt
def grade(
    assignment: str, roster: str, submissions: str, out: str, manifest: str | None, reveal: bool,
    recompute_keys: bool, carry_forward: bool, exports: str | None, strict: bool, bank: str | None,
    hand: str | None,
) -> None:
    """Grade every submission (a folder, or an LMS's zip) against each student's key and write grades, LMS
    imports, feedback and a report into OUT.

    The keys are recomputed from ASSIGNMENT for each ROSTER student, or with --manifest are the keys frozen at
    generation (keys.json)."""
    from gradekit import api
    from gradekit.grading.batch import pending_by_hand

    bar = None

    def progress(done: int, total: int) -> None:  # keys derived for the class, problem by problem
        nonlocal bar
        if not sys.stderr.isatty():
            return
        if bar is None:
            bar = click.progressbar(length=total, label="deriving keys", file=sys.stderr)
            bar.__enter__()
        bar.update(1)
        if done == total:
            bar.__exit__(None, None, None)

    res = api.grade(
        assignment, roster, submissions, out, manifest=manifest, reveal=reveal, bank=bank,
        recompute_keys=recompute_keys, carry_forward=carry_forward, warn=lambda note: log.warning("warning: %s", note),
        progress=progress,
        exports=[n for n in exports.split(",") if n.strip()] if exports is not None else None, hand=hand,
    )
    attention = res.attention()
    missing = len(res.missing)
    log.info("graded %d of %d students (%d without a submission); %d need attention; %d integrity flag(s); "
             "results in %s", res.graded, len(res.grades), missing, len(attention), len(res.flags), out)
    for line in attention:
        log.warning("  %s", line)
    pending = pending_by_hand(res.grades)
    if pending:
        log.info("%d answer(s) to check by hand, left out of the scores: give their points in %s/hand.csv and grade "
                 "again", pending, out)
    if not res.ok:
        raise GradekitError(
            f"expected at least one readable submission, got none; see {out}/report.md", path=submissions
        )
    if strict and attention:
        raise GradekitError(f"expected every file and answer read (--strict), got {len(attention)} that need "
                            f"attention (listed above and in {out}/report.md)", path=submissions)


@main.command()
@click.argument("problem")
@click.option("--published", is_flag=True, help="The values printed in the source (default).")
@click.option("--student", default=None, help="That student's individual values.")
@click.option("--course", default="MEG373", show_default=True, help="Course name (part of the seed).")
@click.option("--salt", default="", help="Assignment salt (part of the seed).")
@click.option("--out", required=True, type=click.Path(file_okay=False), help="Folder for the figures.")
@click.option("--format", "fmt", type=click.Choice(["svg", "png"]), default="svg", show_default=True,
              help="Image format of the files written.")
@_bank_opt
@_assignment_opts
def figures(
    problem: str, published: bool, student: str | None, course: str, salt: str, out: str, fmt: str, bank: str | None,
    assignment: str | None, manifest: str | None,
) -> None:
    """Write every figure of a variant (the scene and the key figures) for authors to preview; with --student
    and --assignment, those of that student's sheet."""
    from pathlib import Path

    from gradekit.figures import write_figures

    v = _student_variant(problem, published, student, None, course, salt, 0, bank, assignment, manifest)
    for path in write_figures(v.result, Path(out), fmt):
        click.echo(str(path))


@main.command("export-quiz")
@click.argument("assignment", type=click.Path(exists=True, dir_okay=False))
@click.option("--format", "fmt", type=click.Choice(["moodle-xml", "canvas-qti"]), required=True,
              help="moodle-xml: Moodle XML (a category per problem, a Cloze question per variant); canvas-qti: a "
              "QTI 1.2 zip for Canvas (a quiz per problem, a question group per answer drawing one variant).")
@click.option("--variants", type=click.IntRange(1, 500), default=20, show_default=True,
              help="Variants drawn per problem (a problem without random parameters has one).")
@click.option("--out", required=True, type=click.Path(dir_okay=False),
              help="File to write (.xml for moodle-xml, .zip for canvas-qti).")
@_bank_opt
def export_quiz(assignment: str, fmt: str, variants: int, out: str, bank: str | None) -> None:
    """Write ASSIGNMENT's problems as quiz pools for the LMS's own quiz engine: per problem N variants with
    statement, figure and numerical answers whose tolerance is the grader's band for that variant."""
    from gradekit.quiz import export_quiz as write

    path = write(assignment, fmt, variants, out, bank)
    log.info("wrote %d variant(s) per problem as %s to %s", variants, fmt, path)


@main.command()
@click.argument("assignment", type=click.Path(exists=True, dir_okay=False))
@click.option("--roster", required=True, type=click.Path(exists=True, dir_okay=False), help="Class roster CSV.")
@click.option("--out", required=True, type=click.Path(file_okay=False), help="Output folder.")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True, help="Worker processes.")
@click.option("--student", default=None, help="Regenerate only this student's documents.")
@click.option("--no-keys", is_flag=True, help="Assignments and answer templates only (no worked keys).")
def generate(assignment: str, roster: str, out: str, jobs: int, student: str | None, no_keys: bool) -> None:
    """Write every student's assignment PDF and answer template, the worked keys, key.csv and the manifest."""
    from gradekit import api

    summary = api.generate(assignment, roster, out, jobs=jobs, student=student, keys=not no_keys, progress=True)
    for w in summary.warnings:
        log.warning("warning: %s", w)
    log.info("wrote documents for %d student(s) to %s in %.1f s", summary.students, out, summary.seconds)


# --- the online page (gradekit.web) ---------------------------------------------------------------

_db_opt = click.option("--db", default=None, metavar="URL",
                       help="postgresql://user@host/db (default: SQLite serve.sqlite3 beside the manifest).")


def _web_service(db: str | None, manifest: str | None, assignment: str | None = None, roster: str | None = None,
                 create_secret: bool = False):
    """The online page's service: the course given (recorded in the database) or the one recorded there."""
    from gradekit.web.grading import Paths
    from gradekit.web.service import open_service

    if db is None and manifest is None:
        raise click.UsageError("give --db URL or --manifest (the SQLite database beside it)")
    paths = None
    if assignment is not None:
        paths = Paths(str(Path(assignment).resolve()), str(Path(roster).resolve()), str(Path(manifest).resolve()))
    return open_service(db, paths, manifest=Path(manifest) if manifest else None, create_secret=create_secret)


@main.command()
@click.argument("assignment", type=click.Path(exists=True, dir_okay=False))
@click.option("--roster", required=True, type=click.Path(exists=True, dir_okay=False), help="Class roster CSV.")
@click.option("--manifest", required=True, type=click.Path(exists=True, dir_okay=False),
              help="manifest.json of generate: the class and its frozen keys.")
@_db_opt
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True, help="Port to listen on.")
@click.option("--prepare", is_flag=True, help="Create or migrate the database, record the course, and exit.")
def serve(assignment: str, roster: str, manifest: str, db: str | None, host: str, port: int, prepare: bool) -> None:
    """Serve the page where students type or upload their answers and are graded at once."""
    service = _web_service(db, manifest, assignment, roster, create_secret=True)
    if prepare:
        service.close()
        log.info("database ready; the course is recorded in it")
        return
    from gradekit.web.app import serve as run

    log.info("serving %s on http://%s:%d/ (Ctrl-C stops)", service.course.assignment.title, host, port)
    run(service, host, port)


@main.command("serve-passwd")
@click.option("--manifest", type=click.Path(exists=True, dir_okay=False), default=None,
              help="manifest.json the page serves (its SQLite database).")
@_db_opt
@click.option("--password-stdin", is_flag=True, help="Read the password from the first line of standard input.")
def serve_passwd(manifest: str | None, db: str | None, password_stdin: bool) -> None:
    """Set the instructor's password of the online page (stored as an scrypt hash, never in clear)."""
    if password_stdin:
        password = sys.stdin.readline().rstrip("\r\n")
    else:
        password = click.prompt("Instructor password", hide_input=True, confirmation_prompt=True)
    if len(password) < 8:
        raise GradekitError(f"expected a password of at least 8 characters, got {len(password)}", field="password")
    if db is None and manifest is None:
        raise click.UsageError("give --db URL or --manifest (the SQLite database beside it)")
    from gradekit.web.service import set_password

    set_password(db, Path(manifest) if manifest else None, password)
    log.info("instructor password set")


@main.command("serve-codes")
@click.option("--roster", required=True, type=click.Path(exists=True, dir_okay=False), help="Class roster CSV.")
@click.option("--manifest", required=True, type=click.Path(exists=True, dir_okay=False),
              help="manifest.json of generate (the secret is kept beside it).")
@click.option("--out", required=True, type=click.Path(dir_okay=False),
              help="CSV to write: student_id,name,access_code.")
def serve_codes(roster: str, manifest: str, out: str) -> None:
    """Write each student's access code of the online page (for a mail merge; keep the file private)."""
    from gradekit.csvsafe import write_csv
    from gradekit.roster import read_roster
    from gradekit.web.access import access_code, load_secret

    secret = load_secret(Path(manifest), create=True)
    students = read_roster(Path(roster))
    write_csv(Path(out), ["student_id", "name", "access_code"],
              [[s.student_id, s.display, access_code(secret, s.student_id)] for s in students])
    log.info("wrote %d access codes to %s", len(students), out)


@main.command()
@_db_opt
@click.option("--manifest", type=click.Path(exists=True, dir_okay=False), default=None,
              help="manifest.json the page serves (its SQLite database).")
@click.option("--out", required=True, type=click.Path(file_okay=False), help="Folder for submissions/ and graded/.")
def export(db: str | None, manifest: str | None, out: str) -> None:
    """Grade the online page's current answers as gradekit grade does: OUT/submissions (the answers CSVs),
    OUT/graded (grades.csv, canvas.csv, moodle.csv, feedback, report.md) and OUT/attempts.csv."""
    service = _web_service(db, manifest)
    try:
        summary = service.export(Path(out))
    finally:
        service.close()
    log.info("graded %d student(s) with answers; %d flag(s); results in %s", summary["graded"], len(summary["flags"]),
             Path(out) / "graded")
