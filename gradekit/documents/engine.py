"""`gradekit generate`: every student's assignment PDF, answer template and worked key, in parallel."""

from __future__ import annotations

import json
import logging
import multiprocessing
import os
import re
import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from gradekit import frozen
from gradekit.assignment import (
    Assignment,
    class_keys,
    frozen_keys,
    keys_for,
    load_assignment,
    manifest,
    redraws_from_manifest,
    seeds_of,
    student_variant,
)
from gradekit.csvsafe import StagedFolder, atomic_write, os_errors, write_csv
from gradekit.documents import html, typeset
from gradekit.documents.context import Picture, Solved, build_context
from gradekit.errors import GradekitError
from gradekit.numbers import fmt
from gradekit.roster import Student, read_roster, safe_names
from gradekit.solving.keys import KeyEntry
from gradekit.solving.sampling import Variant
from gradekit.web.access import SECRET_FILE, access_code, load_secret

log = logging.getLogger("gradekit")

BUILD = ".build"  # the Typst root: figures and bodies, removed when the run ends
KEY_HEADER = ["student_id", "key", "value", "unit", "tolerance", "points", "problem", "description", "sign"]


@dataclass
class GenerateSummary:
    """What a run wrote: counts, paths, timings and warnings (e.g. names no font can draw)."""

    out: Path
    students: int
    assignments: list[Path] = field(default_factory=list)
    keys: list[Path] = field(default_factory=list)
    combined: list[Path] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0


@dataclass(frozen=True)
class _Job:
    assignment: str
    out: str
    keys: bool
    students: tuple[str, ...] = ()  # the roster's ids in order: the class a worker draws its variants for
    secret: str = ""  # the course's secret (hex) that each student's access code of the online page comes from


@dataclass
class _Done:
    student_id: str
    key_rows: list[list]
    warnings: list[str]


def generate(
    assignment: Path,
    roster: Path,
    out: Path,
    *,
    jobs: int = 1,
    student: str | None = None,
    keys: bool = True,
    progress: bool = True,
) -> GenerateSummary:
    """Write every student's documents, the answer key CSV, the combined PDFs and the manifest.

    Layout of *out*: ``students/<safe id>/assignment.pdf`` (PDF/UA-1), ``sheet.html`` (the same sheet
    as HTML) and ``answers.csv``, ``keys/<safe id>.pdf``,
    ``key.csv``, ``keys.json``, ``assignments.pdf``, ``keys.pdf``, ``manifest.json``. Every file is
    written deterministically, so a re-run leaves identical files, and the run's files move in only
    when all are made (`StagedFolder`: a second run on OUT meanwhile is refused). OUT must be empty or
    a previous output of generate; only the files the previous run listed (or, for an older
    gradekit, its manifest names) are ever replaced or removed.

    Args:
        assignment: the assignment YAML.
        roster: the class roster CSV.
        out: the output folder (created).
        jobs: worker processes (1: in this process).
        student: add or replace only this student of the class in *out* (`_add_student`): their
            documents, their entries in keys.json, key.csv and manifest.json (everyone else's stay as
            they were) and the combined PDFs. Only this student is drawn and solved; the roster is
            read for their name alone, so a roster of late students only drops no one.
        keys: also write the worked keys (``keys/``, ``keys.pdf``).
        progress: show a progress bar when stderr is a terminal.

    Returns:
        A `GenerateSummary`.

    Raises:
        GradekitError: a bad assignment, roster, student id or output folder, or a write the file
            system refused (a full disk, a read-only folder), naming the file.
    """
    t0 = time.perf_counter()
    asg = load_assignment(assignment)
    students = read_roster(Path(roster))
    by_id = {s.student_id: s for s in students}
    if student is not None and student not in by_id:
        raise GradekitError(f"expected a student id of the roster, got {student!r}", path=str(roster))
    final = Path(out)
    if final.exists() and not final.is_dir():
        raise GradekitError("expected an output folder, got a file", path=str(final))
    # Everything is built in a staging folder inside OUT and moved in when complete: Ctrl-C leaves OUT as
    # it was. The previous run is read under the folder's lock, so no other run changes it meanwhile.
    with StagedFolder(final, LISTING, merge=student is not None) as stage, os_errors(final):
        previous, unlisted = _previous(final, stage, need_manifest=student is not None)
        # the course's secret, beside the manifest: made with the first run's files (so a failed run leaves
        # none) and kept by every later one, so a re-run prints the same codes and the online page
        # (gradekit serve) checks them with it
        where = final if (final / SECRET_FILE).exists() else stage.root
        secret = load_secret(where / "manifest.json", create=True).hex()
        if student is None:
            summary = _whole_class(asg, Path(assignment), students, stage, jobs, keys, progress, secret)
        else:
            summary = _add_student(asg, Path(assignment), by_id[student], stage, previous, keys, secret)
        stage.commit(
            "gradekit generate output; files listed here are rewritten by the next run, others are left alone",
            extra_previous=unlisted,
            retain=(SECRET_FILE,) if keys else (SECRET_FILE, "keys/", "keys.pdf"),
        )
    summary.seconds = time.perf_counter() - t0
    return summary


def _whole_class(
    asg: Assignment, assignment: Path, students: list[Student], stage: StagedFolder, jobs: int, keys: bool,
    progress: bool, secret: str,
) -> GenerateSummary:
    """Every student of the roster, staged: sheets, keys, key.csv, keys.json, manifest, combined PDFs."""
    final, out = stage.out, stage.root
    names = safe_names(s.student_id for s in students)
    _folders(out, keys)
    # The class's variants (explicit re-draws plus the class de-duplication) and their keys with the
    # catalogued mistakes, drawn and solved once here in class-wide batches, then frozen in
    # keys.json for grading. A worker draws the same class's variants once when it starts (see
    # `_worker_init`): the same batches, so the same numbers to the last bit.
    ids = [s.student_id for s in students]
    class_entries, variants = class_keys(asg, ids)
    redraws = {sid: {label: v.redraw for label, v in per.items()} for sid, per in variants.items()}
    job = _Job(str(assignment), str(out), keys, tuple(ids), secret)
    done: dict[str, _Done] = {}
    work = [(s, names[s.student_id]) for s in students]
    # the combined PDFs are joined here as the students' documents arrive, in roster order: with
    # workers, while they make the next students', so that only the writing is left after the last
    joins = _joins(asg, keys)
    with _bar(len(work), progress) as bar:
        if jobs <= 1 or len(work) <= 1:
            _init(job, asg, variants)
            for s, safe in work:
                done[s.student_id] = _one(s, safe)
                _join(joins, out, safe)
                bar.update(1)
        else:
            # spawn, not fork: a forked child inherits typst's and matplotlib's threads mid-lock
            ctx = multiprocessing.get_context("spawn")
            with ProcessPoolExecutor(jobs, mp_context=ctx, initializer=_worker_init, initargs=(job,)) as pool:
                # one student a task: a student is a third of a second of work and a task's round trip
                # well under a millisecond, so the workers end within one student of each other
                # (chunks of 8 left one core idle for up to 8 students at the end)
                for d, (_, safe) in zip(pool.map(_one_packed, work), work, strict=True):
                    done[d.student_id] = d
                    _join(joins, out, safe)
                    bar.update(1)
        _write_joins(joins, out)
    seeds = {s.student_id: seeds_of(asg, s.student_id, redraws[s.student_id]) for s in students}
    frozen_text = frozen.dumps(class_entries)
    _write_keys(out, class_entries, frozen_text, manifest(asg, ids, seeds, frozen_text))
    summary = GenerateSummary(final, len(students))
    _summarise(summary, students, names, done, keys)
    summary.combined = [final / "assignments.pdf"] + ([final / "keys.pdf"] if keys else [])
    return summary


def _add_student(
    asg: Assignment, assignment: Path, s: Student, stage: StagedFolder, previous: dict | None, keys: bool,
    secret: str,
) -> GenerateSummary:
    """One student added to (or replaced in) the class a previous run wrote into OUT, staged.

    Everyone else's entries of keys.json and manifest.json are kept as they are: their sheets were
    printed from them. The student's re-draw counter is the assignment's explicit one for them, else
    the one the manifest recorded (their sheet as printed, with the current bank), else 0; it moves on
    while their answers repeat another student's frozen ones (the class de-duplication, against the
    keys as frozen). Only this student is drawn and solved. With no previous output the class is this
    student alone.
    """
    final, out = stage.out, stage.root
    sid = s.student_id
    path = final / "manifest.json"
    old_keys = _previous_keys(asg, path, previous) if previous is not None else {}
    order = list(previous["students"]) if previous is not None else []
    recorded = redraws_from_manifest(path).get(sid, {}) if previous is not None else {}
    variants: dict[str, Variant] = {}
    mine: list[KeyEntry] = []
    for item in asg.items:
        v = _unique_variant(asg, item, sid, asg.redraws.get(sid, {}).get(item.label, recorded.get(item.label, 0)),
                            old_keys)
        variants[item.label] = v
        mine += keys_for(asg, item, sid, v)
    if sid not in order:
        order.append(sid)
    entries = [e for other in order for e in (mine if other == sid else old_keys[other])]
    frozen_text = frozen.dumps(entries)
    _check_frozen(frozen.loads(frozen_text, str(final / frozen.FILE)), {**old_keys, sid: mine}, sid, path)
    data = previous if previous is not None else manifest(asg, [], {}, frozen_text)
    data["students"][sid] = seeds_of(asg, sid, {label: v.redraw for label, v in variants.items()})
    data["keys"] = {**data.get("keys", {}), "file": frozen.FILE, "sha256": frozen.sha256(frozen_text)}
    names = safe_names(order)
    _folders(out, keys)
    job = _Job(str(assignment), str(out), keys, (sid,), secret)
    _init(job, asg, {sid: variants})
    done = {sid: _one(s, names[sid])}
    _write_keys(out, entries, frozen_text, data)
    summary = GenerateSummary(final, 1)
    _summarise(summary, [s], names, done, keys)
    # the combined PDFs again, in the class's order: the others' documents are linked into the staging
    # folder for the concatenation and unlinked before the commit (they stay in OUT as they are)
    linked, present = [], []
    for other in order:
        parts = [f"students/{names[other]}/assignment.pdf"] + ([f"keys/{names[other]}.pdf"] if keys else [])
        if other != sid:
            if not all((final / rel).is_file() for rel in parts):
                summary.warnings.append(f"student {other}: no documents in {final}; the combined PDFs go without them")
                continue
            for rel in parts:
                _link(final / rel, out / rel)
            linked += parts
        present.append(names[other])
    _combine(out, asg, present, keys)
    for rel in linked:
        (out / rel).unlink()
    summary.combined = [final / "assignments.pdf"] + ([final / "keys.pdf"] if keys else [])
    return summary


def _unique_variant(asg: Assignment, item, sid: str, redraw: int, others: dict[str, list[KeyEntry]]) -> Variant:
    """*sid*'s variant of *item* from re-draw *redraw* on, re-drawn while its answers equal another
    student's frozen answers (as `class_variants` re-draws a student whose values repeat an earlier one's)."""
    v = student_variant(asg, item, sid, redraw)
    if not any(p.random for p in item.problem.parameters.values()):
        return v  # everyone has the published values
    prefix = f"{item.label}."
    taken = {
        tuple(e.value for e in entries if e.key.startswith(prefix)) for other, entries in others.items() if other != sid
    }
    while tuple(float(a.value) for a in v.result.answers) in taken and v.redraw < REDRAW_LIMIT:
        v = student_variant(asg, item, sid, v.redraw + 1)
    return v


REDRAW_LIMIT = 50  # as `class_variants`


def _previous_keys(asg: Assignment, path: Path, previous: dict) -> dict[str, list[KeyEntry]]:
    """The frozen keys of the class a previous run wrote, checked to be of this assignment."""
    info = previous.get("assignment") or {}
    problems = previous.get("problems") or {}
    theirs = (info.get("course"), info.get("salt"), {label: p.get("id") for label, p in problems.items()
                                                     if isinstance(p, dict)})
    ours = (asg.course, asg.salt, {it.label: it.problem.id for it in asg.items})
    if theirs != ours:
        raise GradekitError(
            f"expected the output of this assignment (course {ours[0]!r}, salt {ours[1]!r}, problems {ours[2]}), "
            f"got one of course {theirs[0]!r}, salt {theirs[1]!r}, problems {theirs[2]}; --student adds a student "
            "to the class generated there: generate the whole class into a new folder instead",
            path=str(path),
        )
    found = frozen_keys(path)
    if found is None:
        raise GradekitError(
            "expected the frozen keys (keys.json) of the class beside the manifest, got a manifest without them "
            "(an older gradekit); generate the whole class again to add a student",
            path=str(path),
        )
    unkeyed = [other for other in previous["students"] if other not in found]
    if unkeyed:
        raise GradekitError(
            f"expected a frozen key for every student of the manifest, got none for {', '.join(unkeyed[:3])}"
            f"{', …' if len(unkeyed) > 3 else ''} (keys.json and manifest.json of different runs)",
            path=str(path),
        )
    return {other: found[other] for other in found}


def _check_frozen(loaded, expected: dict[str, list[KeyEntry]], sid: str, path: Path) -> None:
    """Refuse a keys.json that does not give back every student's entries: keys.json holds the unit,
    points, description, sign and tolerance of an answer once for the class, so a bank or assignment
    edit that changed them cannot be given to one student alone."""
    for other, entries in expected.items():
        if loaded[other] != entries:
            key = next((a.key for a, b in zip(loaded[other], entries, strict=False) if a != b), entries[0].key)
            raise GradekitError(
                f"expected {key} of student {sid} with the unit, points, description, sign and tolerance the class "
                "was generated with, got another (the bank or the assignment changed them); undo that change to "
                "add one student, or generate the whole class into a new folder",
                path=str(path),
            )


def _link(src: Path, dst: Path) -> None:
    """*dst* as a hard link to *src* (a copy where the file system has no hard links)."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.link(src, dst)
    except OSError:
        shutil.copyfile(src, dst)


def _folders(out: Path, keys: bool) -> None:
    for sub in ("students", "keys", BUILD) if keys else ("students", BUILD):
        (out / sub).mkdir(parents=True, exist_ok=True)


def _write_keys(out: Path, entries: list[KeyEntry], frozen_text: str, data: dict) -> None:
    """key.csv, keys.json and manifest.json of the class, staged; the Typst build folder goes."""
    write_csv(out / "key.csv", KEY_HEADER, [_key_row(e) for e in entries])
    atomic_write(out / frozen.FILE, frozen_text)
    atomic_write(out / "manifest.json", json.dumps(data, indent=2, ensure_ascii=False) + "\n")
    shutil.rmtree(out / BUILD, ignore_errors=True)


def _summarise(summary: GenerateSummary, made: list[Student], names: dict[str, str], done: dict, keys: bool) -> None:
    final = summary.out
    for s in made:
        summary.assignments.append(final / "students" / names[s.student_id] / "assignment.pdf")
        if keys:
            summary.keys.append(final / "keys" / f"{names[s.student_id]}.pdf")
        summary.warnings += done[s.student_id].warnings


LISTING = ".gradekit-generate"  # the files the last run wrote (the next full run removes those it does not rewrite)


def _previous(out: Path, stage: StagedFolder, need_manifest: bool) -> tuple[dict | None, list[str]]:
    """The previous run's manifest (None when not needed or there was no run) and, for an older gradekit
    that wrote no listing, its files: those its manifest names.

    Refuses a folder that holds other files and no sign of generate (a listing or its manifest.json),
    as `grade` does: nothing gradekit did not write is ever replaced or removed.
    """
    listed = (out / LISTING).is_file()
    path = out / "manifest.json"
    data = None
    if os.path.lexists(path) and (need_manifest or not listed):
        data = _manifest_at(path)
    elif listed and need_manifest:
        raise GradekitError("expected the manifest.json of the previous generate run, got none", path=str(path))
    if listed:
        return data, []
    if data is not None:
        return data, _unlisted_outputs(data)
    others = sorted(p.name for p in out.iterdir()  # the course's secret may be carried over to keep the codes
                    if p != stage.root and p.name not in (StagedFolder.INCOMPLETE, SECRET_FILE))
    if others:
        raise GradekitError(
            f"expected an empty output folder or one gradekit generate wrote before, got a folder of other files "
            f"({', '.join(others[:3])}{', …' if len(others) > 3 else ''}); choose another --out",
            path=str(out),
        )
    return None, []


def _manifest_at(path: Path) -> dict:
    """The manifest.json generate wrote into OUT (refused when it is not one)."""
    try:
        if not path.is_file():
            raise ValueError("not a regular file")
        data = json.loads(path.read_bytes())
        if not (isinstance(data, dict) and "gradekit" in data and isinstance(data.get("students"), dict)):
            raise ValueError("another JSON document")
    except (OSError, ValueError) as exc:
        raise GradekitError(f"expected a manifest.json written by gradekit generate, got {exc}",
                            path=str(path)) from None
    return data


def _unlisted_outputs(data: dict) -> list[str]:
    """What an older gradekit (no listing) wrote into OUT: the fixed names and the documents of the
    students its manifest names (a file of any other name is the user's)."""
    found = ["key.csv", frozen.FILE, "manifest.json", "assignments.pdf", "keys.pdf"]
    for safe in safe_names(data["students"]).values():
        found += [f"students/{safe}/{name}" for name in ("assignment.pdf", "answers.csv", "sheet.html")]
        found.append(f"keys/{safe}.pdf")
    return sorted(found)


class _NoBar:
    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None

    def update(self, n: int) -> None:
        return None


def _bar(n: int, progress: bool):
    if not (progress and sys.stderr.isatty()):
        return _NoBar()
    import click  # the progress bar only; everything else stays free of click

    return click.progressbar(length=n, label="Generating", file=sys.stderr, show_pos=True)


# --- worker side: one assignment, one compiler, per process --------------------------------------

_STATE: dict = {}


def _init(job: _Job, asg: Assignment | None = None, variants: dict | None = None) -> None:
    out = Path(job.out)
    root = out / BUILD
    root.mkdir(parents=True, exist_ok=True)
    _STATE.update(
        job=job,
        asg=asg or load_assignment(job.assignment),
        out=out,
        root=root,
        compiler=typeset.Compiler(root),
        variants=variants or {},
        fonts=typeset.available_fonts(),
        drawn={},  # figures drawn in this run (`_drawn`): a new run, perhaps of an edited bank, draws anew
    )


def _worker_init(job: _Job) -> None:
    """A pool worker: Typst on one thread (its thread pool would otherwise start a thread per core in
    every worker, so that the workers' threads fight over the cores), then `_init` with the class's
    variants.

    The worker draws and solves the class's variants itself, in the same class-wide batches as the
    parent (`class_keys` with the same roster, without the mistakes): the printed numbers are those
    frozen in keys.json to the last bit, as with one job. That costs about 0.5 ms a student once,
    where solving each student's variants on their own (`sampling.given`) cost 8 ms a student, and a
    solved variant cannot be sent (its results are closures)."""
    os.environ.setdefault("RAYON_NUM_THREADS", "1")  # read when Typst first starts its pool
    asg = load_assignment(job.assignment)
    variants = class_keys(asg, list(job.students), with_mistakes=False, need_keys=False)[1]
    _init(job, asg, variants)


def _one_packed(pair: tuple[Student, str]) -> _Done:
    return _one(*pair)


def _one(s: Student, safe: str) -> _Done:
    """Everything of one student: figures, sheet, answers.csv, key; returns the key rows."""
    asg: Assignment = _STATE["asg"]
    job: _Job = _STATE["job"]
    out: Path = _STATE["out"]
    root: Path = _STATE["root"]
    comp: typeset.Compiler = _STATE["compiler"]
    warnings = _font_warnings(s)
    accessible = not warnings  # PDF/UA-1 refuses a glyph no font draws: a tagged PDF then
    build = root / "s" / safe
    build.mkdir(parents=True, exist_ok=True)
    solved = []
    for item in asg.items:
        v = _STATE["variants"][s.student_id][item.label]
        scenes, pics = _pictures(v.result, item.label, build, safe, job.keys, warnings, s)
        solved.append(Solved(item, v, tuple(scenes), tuple(pics)))
    folder = out / "students" / safe
    folder.mkdir(parents=True, exist_ok=True)
    ctx = build_context(asg, s, solved, key=False) | {
        "fonts": _STATE["fonts"], "access_code": access_code(bytes.fromhex(job.secret), s.student_id)}
    body = typeset.render("assignment.typ.j2", ctx)
    meta = _metadata(f"{asg.course} {asg.title}: {s.display} ({s.student_id})", asg.course)
    atomic_write(folder / "assignment.pdf", _compiled(comp, meta + body, accessible, asg, s, "sheet", warnings))
    atomic_write(folder / "sheet.html", html.sheet(ctx))
    rows = []
    key_rows = []
    for sv in solved:
        for e in keys_for(asg, sv.item, s.student_id, sv.variant, with_mistakes=False):
            rows.append([s.student_id, e.key, "", e.unit])
            key_rows.append(_key_row(e))
    write_csv(folder / "answers.csv", ["student_id", "key", "value", "unit"], rows)
    if job.keys:
        kctx = build_context(asg, s, solved, key=True) | {"fonts": _STATE["fonts"]}
        kbody = typeset.render("key.typ.j2", kctx)
        meta = _metadata(f"{asg.course} {asg.title}: worked key, {s.display} ({s.student_id})", asg.course)
        atomic_write(out / "keys" / f"{safe}.pdf", _compiled(comp, meta + kbody, accessible, asg, s, "worked key",
                                                             warnings))
    return _Done(s.student_id, key_rows, warnings)


def _compiled(comp: typeset.Compiler, source: str, accessible: bool, asg: Assignment, s: Student, what: str,
              warnings: list[str]) -> bytes:
    """The PDF of *source*: PDF/UA-1 when *accessible*. Text of a problem file that no installed font
    draws makes PDF/UA-1 refuse the document: it is then a tagged PDF, with a warning naming the file
    and field. Any other failure is one line naming the student and, where Typst quotes it, the
    problem file and field the text comes from."""
    try:
        return comp.pdf(source, accessible=accessible)
    except typeset.TypstFailure as exc:
        where = _culprit(asg, exc.quoted)
        if accessible and exc.missing_glyph:
            warnings.append(f"{where or 'a problem file'}: no installed font draws {exc.quoted!r}; the {what} of "
                            f"student {s.student_id} is a tagged PDF, not PDF/UA-1 (install "
                            f"{typeset.font_hint(exc.quoted)})")
            return comp.pdf(source, accessible=False)
        raise GradekitError(f"typst cannot typeset the {what} of student {s.student_id}: {exc.message}",
                            path=where or None) from None


def _culprit(asg: Assignment, quoted: str) -> str:
    """``file: field`` of the first problem field of *asg* holding *quoted* (empty when none does)."""
    if not quoted:
        return ""
    for item in asg.items:
        p = item.problem
        fields = {"title": p.title, "statement": p.statement}
        fields |= {f"labels.{k}": v for k, v in p.labels.items()}
        fields |= {f"points.{k}": v for k, v in p.point_names.items()}
        for name, par in p.parameters.items():
            fields |= {f"parameters.{name}.symbol": par.symbol, f"parameters.{name}.description": par.description}
        for a in p.answers:
            fields[f"answers.{a.key}.description"] = a.description
        for name, value in fields.items():
            if isinstance(value, str) and quoted in value:
                return f"{p.path}: {name}"
    return ""


def _metadata(title: str, author: str) -> str:
    """The document's title (a PDF/UA-1 reader shows it, and the combined PDFs name each student's
    bookmark with it), author and language."""
    return (f"#set document(title: {typeset.string(title)}, author: {typeset.string(author)}, date: none)\n"
            '#set text(lang: "en")\n')


def _key_row(e) -> list:
    return [
        e.student_id,
        e.key,
        float(fmt(e.value, 10)),
        e.unit,
        e.tolerance.describe(),
        e.points,
        e.problem,
        e.description,
        e.sign_convention,
    ]


def _font_warnings(s: Student) -> list[str]:
    missing = typeset.missing_glyphs(s.display + s.section)
    if not missing:
        return []
    msg = (
        f"student {s.student_id}: no installed font draws {missing!r} of the name {s.display!r}; "
        f"it prints as empty boxes and their documents are tagged PDF, not PDF/UA-1 "
        f"(install {typeset.font_hint(missing)})"
    )
    return [msg]  # reported once, by the caller, from GenerateSummary.warnings


_SVG_WIDTH = re.compile(rb'<svg[^>]*?\swidth="([0-9.]+)(pt|px)?"')
TEXT_WIDTH_PT = (210 - 40) / 25.4 * 72  # A4 minus the 2 cm margins of templates/_style.typ.j2
LANDSCAPE_WIDTH_PT = (297 - 40) / 25.4 * 72


def _svg_width(svg: bytes) -> float:
    """The SVG's natural width in points (matplotlib writes pt)."""
    m = _SVG_WIDTH.search(svg[:2000])
    if not m:
        return 0.0
    return float(m.group(1)) * (0.75 if m.group(2) == b"px" else 1.0)


def _pictures(result, label: str, build: Path, safe: str, keys: bool, warnings: list[str], s: Student):
    """Write the student's scene(s) and, for keys, the key figures; return their `Picture`s."""
    p = result.problem
    true_scale = p.method == "graphical" and p.figure.true_scale is not None
    scenes = []
    cases = [c.name for c in result.cases] if len(result.cases) > 1 else [None]
    for case in cases:
        name = f"{label}-scene{'-' + _slug(case) if case else ''}.svg"
        svg, alt = _drawn(result, ("scene", case, true_scale))
        (build / name).write_bytes(svg)
        scale, wide = "", False
        if true_scale:
            scale = f"Drawn to scale {_ratio(p.figure.true_scale)}: print at 100 % (no fit to page)."
            width = _svg_width(svg)
            wide = width > TEXT_WIDTH_PT
            if width > LANDSCAPE_WIDTH_PT:
                warnings.append(
                    f"student {s.student_id}: {label} true-scale figure is {width:.0f} pt wide, "
                    f"wider than a landscape page's text ({LANDSCAPE_WIDTH_PT:.0f} pt)"
                )
        caption = f"{label}: {p.title}" + (f", position {case}" if case else "") + "."
        scenes.append(Picture(f"/s/{safe}/{name}", caption, true_scale, scale, wide, alt, svg))
    pics = []
    if keys:
        for slug, caption, svg, alt in _drawn(result, ("key",)):
            name = f"{label}-key-{_slug(slug)}.svg"
            (build / name).write_bytes(svg)
            pics.append(Picture(f"/s/{safe}/{name}", caption, alt=alt))
    return scenes, pics


_DRAWN_MAX = 256


def _drawn(result, what: tuple):
    """(SVG, alt text) of a scene, or (slug, caption, SVG, alt text) of the key figures, drawn once per
    distinct variant.

    Students share a variant when a problem has few (or no) random parameters; drawing is most
    of the cost of a run, so each process remembers the last few hundred it drew in this run (kept
    with the run's state, so a later run in the same process never reuses a figure of an older
    problem file).
    """
    from gradekit import figures

    p = result.problem
    cache_key = (p.id, p.path, tuple(sorted(result.values.items())), what)
    drawn = _STATE["drawn"]
    hit = drawn.get(cache_key)
    if hit is not None:
        return hit
    if what[0] == "scene":
        out = figures.scene_described(result, what[1], true_scale=what[2])
    else:
        out = figures.key_figures_described(result)
    if len(drawn) >= _DRAWN_MAX:
        drawn.pop(next(iter(drawn)))
    drawn[cache_key] = out
    return out


def _ratio(scale: float) -> str:
    if scale >= 1:
        return f"{fmt(scale, 3)}:1"
    return f"1:{fmt(1 / scale, 3)}"


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]+", "_", str(text)).strip("_") or "x"


# --- the combined PDFs ------------------------------------------------------------------------


def _combine(out: Path, asg: Assignment, safes: list[str], keys: bool) -> None:
    """``assignments.pdf`` and ``keys.pdf``: the documents of the students *safes*, joined in that order."""
    joins = _joins(asg, keys)
    for safe in safes:
        _join(joins, out, safe)
    _write_joins(joins, out)


def _joins(asg: Assignment, keys: bool) -> dict[str, Joined]:
    """The combined PDFs, empty, by file name: ``assignments.pdf`` and (with keys) ``keys.pdf``.

    They join the finished per-student PDFs (pikepdf) rather than typeset one document of every
    body, which would compile the class twice."""
    joins = {"assignments.pdf": Joined(f"{asg.course} {asg.title}: assignments", asg.course)}
    if keys:
        joins["keys.pdf"] = Joined(f"{asg.course} {asg.title}: worked keys", asg.course)
    return joins


def _join(joins: dict[str, Joined], out: Path, safe: str) -> None:
    """Add one student's sheet and key to the combined PDFs."""
    joins["assignments.pdf"].add(out / "students" / safe / "assignment.pdf")
    if "keys.pdf" in joins:
        joins["keys.pdf"].add(out / "keys" / f"{safe}.pdf")


def _write_joins(joins: dict[str, Joined], out: Path) -> None:
    for name, joined in joins.items():
        joined.write(out / name)


def concatenate_pdfs(target: Path, parts: list[Path], title: str, author: str) -> None:
    """*parts* one after the other in *target* (see `Joined`)."""
    joined = Joined(title, author)
    for path in parts:
        joined.add(path)
    joined.write(target)


class Joined:
    """A combined PDF made part by part: the parts one after the other, each starting on an odd page
    (duplex), each under a bookmark of its own named by the part's title (the student), with the
    part's bookmarks under it, and with the parts' tags: one structure tree holding each part's, the
    language, /MarkInfo. A part is copied when it is added (`add`), so a run can join the parts as
    they are made; `write` links what was added and writes the file.

    pikepdf (qpdf) copies the objects without parsing them in Python; it copies every object of one
    part once, so the copied structure elements point at the copied pages. The page tree and the
    outline are linked here rather than through pikepdf's page list and outline helpers, which made
    the time grow with the square of the class. Each part's pages hang under a page-tree node of
    their own (a nested page tree, ISO 32000 §7.7.3.2). The structure tree (ISO 32000 §14.7): each
    part's top elements become children of one root; its parent-tree keys (a page's
    /StructParents, an annotation's /StructParent) move past those of the parts before it; its
    element ids (a table's header cells, which the data cells name in /Headers) get the part's
    number as a prefix, as two students' tables have the same ids.
    """

    def __init__(self, title: str, author: str) -> None:
        import pikepdf
        from pikepdf import Dictionary, Name

        self.title, self.author = title, author
        self.out = pikepdf.Pdf.new()
        self.tree = self.out.make_indirect(Dictionary(Type=Name.StructTreeRoot))
        self.nodes: list = []
        self.bookmarks: list = []  # one per part, the part's own outline items under it
        self.elements: list = []  # every part's top structure elements, in order
        self.nums: list = []  # the merged parent tree's (key, value) pairs
        self.ids: list = []  # the merged id tree's (id, element) pairs
        self.roles: dict = {}
        self.lang = None
        self.total = 0  # pages so far
        self.next_key = 0
        self.parts = 0

    def add(self, path: Path) -> None:
        """Copy the part at *path* in after those added before it."""
        import pikepdf
        from pikepdf import Array, Dictionary, Name

        out = self.out
        with pikepdf.Pdf.open(path) as src:
            node = out.make_indirect(Dictionary(Type=Name.Pages, Parent=out.Root.Pages))
            kids = []
            if self.total % 2:
                box = src.pages[0].mediabox
                kids.append(out.make_indirect(Dictionary(
                    Type=Name.Page, Parent=node, MediaBox=Array([0, 0, float(box[2]), float(box[3])]),
                    Contents=out.make_stream(b""), Resources=Dictionary())))
            copies = [out.copy_foreign(page.obj) for page in src.pages]
            for page in copies:
                page.Parent = node
            kids += copies
            node.Kids = Array(kids)
            node.Count = len(kids)
            self.nodes.append(node)
            self.total += len(kids)
            self.lang = self.lang if self.lang is not None else src.Root.get(Name.Lang)
            if copies:
                mark = out.make_indirect(Dictionary(Title=pikepdf.String(_part_title(src, path)),
                                                    Dest=Array([copies[0], Name.Fit])))
                inner = []
                if Name.Outlines in src.Root:
                    item = out.copy_foreign(src.Root.Outlines).get(Name.First)
                    while item is not None:
                        _fix_destinations(item, copies[0])
                        inner.append(item)
                        item = item.get(Name.Next)
                _hang(mark, inner)
                self.bookmarks.append(mark)
            if Name.StructTreeRoot in src.Root:
                self.next_key = _merge_structure(out.copy_foreign(src.Root.StructTreeRoot), copies, self.tree,
                                                 self.parts, self.next_key, self.elements, self.nums, self.ids,
                                                 self.roles)
        self.parts += 1

    def write(self, target: Path) -> None:
        """Link the parts added and write the combined PDF to *target* (the same parts give the same bytes)."""
        import io

        import pikepdf
        from pikepdf import Array, Dictionary, Name

        out, tree = self.out, self.tree
        root = out.Root.Pages
        root.Kids = Array(self.nodes)
        root.Count = self.total
        if self.bookmarks:
            outlines = out.make_indirect(Dictionary(Type=Name.Outlines))
            outlines.Count = _hang(outlines, self.bookmarks)
            out.Root.Outlines = outlines
        if self.elements:
            tree.K = Array(self.elements)
            tree.ParentTree = out.make_indirect(Dictionary(Nums=Array([x for pair in self.nums for x in pair])))
            tree.ParentTreeNextKey = self.next_key
            if self.ids:
                tree.IDTree = out.make_indirect(Dictionary(Names=Array([x for pair in sorted(self.ids) for x in pair])))
            if self.roles:
                tree.RoleMap = Dictionary(self.roles)
            out.Root.StructTreeRoot = tree
            out.Root.MarkInfo = Dictionary(Marked=True)
        if self.lang is not None:
            out.Root.Lang = self.lang
        out.Root.ViewerPreferences = Dictionary(DisplayDocTitle=True)
        out.docinfo["/Title"] = self.title
        out.docinfo["/Author"] = self.author
        buf = io.BytesIO()
        # object streams: the parts' thousands of small structure elements compressed together, which
        # makes the file a third of the size and is quicker to write than each object on its own; the
        # version the parts declare (Typst writes PDF 1.7, the base of PDF/UA-1), not pikepdf's default
        out.save(buf, deterministic_id=True, object_stream_mode=pikepdf.ObjectStreamMode.generate, min_version="1.7")
        atomic_write(target, buf.getvalue())
        out.close()


def _part_title(src, path: Path) -> str:
    """A part's title (the student's document title), else its file name."""
    import pikepdf

    title = src.docinfo.get(pikepdf.Name.Title) if src.docinfo is not None else None
    return str(title) if title is not None else path.stem


def _hang(parent, items: list) -> int:
    """Hang outline *items* under *parent* as its children (First, Last, Prev, Next, Parent); returns
    how many are visible below *parent* (its /Count when open)."""
    import pikepdf
    from pikepdf import Name

    if not items:
        return 0
    parent.First, parent.Last = items[0], items[-1]
    visible = 0
    for before, item, after in zip([None, *items[:-1]], items, [*items[1:], None], strict=True):
        item.Parent = parent
        for key, other in ((Name.Prev, before), (Name.Next, after)):
            if other is None:
                if key in item:
                    del item[key]
            else:
                item[key] = other
        visible += 1 + max(int(item.get(Name.Count, 0)), 0)
    if not isinstance(parent.get(Name.Type), pikepdf.Name):  # an outline item, not the outline root
        parent.Count = visible
    return visible


def _tree_pairs(node, key: str) -> list:
    """The (key, value) pairs of a number tree (*key* "/Nums") or name tree ("/Names"), leaves in order."""
    out = []
    leaf = node.get(key)
    if leaf is not None:
        out += [(leaf[i], leaf[i + 1]) for i in range(0, len(leaf) - 1, 2)]
    for kid in node.get("/Kids", []):
        out += _tree_pairs(kid, key)
    return out


def _merge_structure(part, pages: list, tree, number: int, start: int, elements: list, nums: list, ids: list,
                     roles: dict) -> int:
    """Add one part's copied structure tree *part* to the combined *tree* (see `concatenate_pdfs`);
    returns the next free parent-tree key."""
    import pikepdf
    from pikepdf import Array, Name

    pairs = _tree_pairs(part.ParentTree, "/Nums") if Name.ParentTree in part else []
    used = max((int(k) for k, _ in pairs), default=-1) + 1
    end = start + max(int(part.get(Name.ParentTreeNextKey, used)), used)
    nums += [(int(k) + start, v) for k, v in pairs]
    for page in pages:
        if Name.StructParents in page:
            page.StructParents = int(page.StructParents) + start
        for annot in page.get(Name.Annots, []):
            if Name.StructParent in annot:
                annot.StructParent = int(annot.StructParent) + start
    kids = part.K if isinstance(part.get(Name.K), Array) else [part.K] if Name.K in part else []
    for kid in kids:
        if isinstance(kid, pikepdf.Dictionary):
            kid.P = tree
        elements.append(kid)
    prefix = f"p{number}-"
    renamed = {}
    for name, element in (_tree_pairs(part.IDTree, "/Names") if Name.IDTree in part else []):
        new = prefix + bytes(name).decode("latin-1")
        renamed[bytes(name)] = pikepdf.String(new)
        element.ID = pikepdf.String(new)
        ids.append((new, element))
    if renamed:  # a data cell names its header cells by id: the new ids
        for cell in _cells_naming(ids[-len(renamed):]):
            for attrs in (cell.A if isinstance(cell.A, Array) else [cell.A]):
                if isinstance(attrs, pikepdf.Dictionary) and Name.Headers in attrs:
                    attrs.Headers = Array([renamed.get(bytes(h), h) for h in attrs.Headers])
    for role, target in (part.get(Name.RoleMap) or {}).items():
        roles.setdefault(role, target)
    return end


def _cells_naming(named: list) -> list:
    """The cells (with attributes) of every table that holds one of the *named* elements."""
    import pikepdf
    from pikepdf import Name

    tables, seen = [], set()
    for _, element in named:
        t = element
        while t is not None and t.get(Name.S) not in (Name.Table,):
            t = t.get(Name.P)
        if t is not None and t.objgen not in seen:
            seen.add(t.objgen)
            tables.append(t)
    parts = (Name.TR, Name.THead, Name.TBody, Name.TFoot, Name.TH, Name.TD)
    cells = []
    stack = list(tables)
    while stack:
        kids = stack.pop().get(Name.K)
        kids = list(kids) if isinstance(kids, pikepdf.Array) else [kids] if kids is not None else []
        for k in kids:
            if isinstance(k, pikepdf.Dictionary) and k.get(Name.S) in parts:
                stack.append(k)
                if Name.A in k:
                    cells.append(k)
    return cells


def _fix_destinations(item, first) -> None:
    """Point a copied bookmark (and its children) that does not go to a page of its part (a named
    destination or an action: their targets are not copied) at the part's first page."""
    import pikepdf

    dest = item.get(pikepdf.Name.Dest)
    if not (isinstance(dest, pikepdf.Array) and len(dest) >= 1 and isinstance(dest[0], pikepdf.Dictionary)):
        item.Dest = pikepdf.Array([first, pikepdf.Name.Fit])
        if pikepdf.Name.A in item:
            del item.A
    child = item.get(pikepdf.Name.First)
    while child is not None:
        _fix_destinations(child, first)
        child = child.get(pikepdf.Name.Next)


__all__ = ["generate", "GenerateSummary"]
