"""The class roster: plain CSV, Canvas gradebook exports and Moodle exports, read as they come."""

from __future__ import annotations

import csv
import hashlib
import io
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from gradekit.csvsafe import decode_bytes, sniff_delimiter, unguard
from gradekit.errors import ErrorList, GradekitError


@dataclass(frozen=True)
class Student:
    """One student of the class.

    ``student_id`` is the id the assignment was generated for (the institution's student number:
    Canvas' SIS User ID, Moodle's ID number). ``lms_id`` is the LMS's own user id (Canvas' ``ID``
    column) when known: LMS downloads name submission files with it, and Canvas imports match it.
    """

    student_id: str
    name: str
    email: str = ""
    section: str = ""
    sis_login: str = ""
    lms_id: str = ""

    @property
    def display(self) -> str:
        """The name, or the id when the roster gave no name."""
        return self.name or self.student_id


def header_key(cell: str) -> str:
    """A header cell reduced for matching: ``' SIS User ID'`` -> ``sis_user_id``."""
    return re.sub(r"[^a-z0-9]+", "_", cell.replace("\ufeff", "").strip().lower()).strip("_")


_PLAIN = {
    "student_id": ("student_id", "studentid", "id", "sid", "student_number", "student_no"),
    "name": ("name", "student_name", "full_name", "student"),
    "email": ("email", "email_address", "e_mail", "mail"),
    "section": ("section", "group", "groups", "class"),
    "sis_login": ("sis_login", "sis_login_id", "login", "username", "user_name"),
}


def _find(header: list[str], names: tuple[str, ...]) -> int | None:
    for name in names:
        if name in header:
            return header.index(name)
    return None


def _cell(row: list[str], index: int | None) -> str:
    """A roster cell, with the formula guard (``'=…``) of a spreadsheet-safe export removed."""
    if index is None or index >= len(row):
        return ""
    return unguard(row[index].strip())


def _first_last(name: str) -> str:
    """Canvas writes ``Last, First``; feedback reads better as ``First Last``."""
    last, sep, first = name.partition(",")
    return f"{first.strip()} {last.strip()}".strip() if sep else name.strip()


def read_roster(path: Path) -> list[Student]:
    """Read a roster CSV in plain, Canvas or Moodle form.

    Plain: ``student_id,name[,email][,section]`` with a header (any case/spacing) or without.
    Canvas: ``Student, ID, SIS User ID, SIS Login ID, Section`` (the id is the SIS User ID,
    falling back to ``ID``; the "Points Possible" row and other rows without a student are
    skipped; ``Last, First`` becomes ``First Last``; ``ID`` is kept as ``lms_id``). Moodle's
    gradebook export: ``First name, Last name`` (or ``Surname``), ``ID number``, ``Email address``
    (the id is the ID number, else the email address on a site without ID numbers). Moodle's
    grading worksheet: ``Identifier`` (``Participant 12345``, kept as ``lms_id``), ``Full name``,
    ``ID number`` if shown, ``Email address``. UTF-8 with or without BOM, UTF-16, cp1252.

    Args:
        path: the roster file.

    Returns:
        The students in file order.

    Raises:
        GradekitError: the file cannot be read or holds no student; an `ErrorList` with one
            line per bad row (empty or duplicate id, too many cells).
    """
    where = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        message = f"expected a readable roster file, got {exc.strerror}"
        raise GradekitError(message, path=where) from exc
    text, _ = decode_bytes(data)
    if "\x00" in text:
        raise GradekitError("expected a CSV text file, got binary data", path=where)
    try:
        rows = list(csv.reader(io.StringIO(text, newline=""), delimiter=sniff_delimiter(text)))
    except csv.Error as exc:
        raise GradekitError(f"expected a CSV file, got {exc}", path=where) from exc
    numbered = [(n, row) for n, row in enumerate(rows, start=1) if any(c.strip() for c in row)]
    if not numbered:
        message = "expected a header and one row per student, got an empty file"
        raise GradekitError(message, path=where)
    header = [header_key(c) for c in numbered[0][1]]
    if "student" in header and ("sis_user_id" in header or "id" in header):
        layout, rows_, id_field, width = _canvas(header), numbered[1:], "SIS User ID", None
    elif "identifier" in header and "full_name" in header:
        layout, rows_, id_field, width = _moodle_worksheet(header), numbered[1:], "ID number", None
    elif ("first_name" in header or "firstname" in header) and (
        "surname" in header or "last_name" in header or "lastname" in header
    ):
        layout, rows_, id_field, width = _moodle(header), numbered[1:], "ID number", None
    elif _find(header, _PLAIN["student_id"]) is None:  # no header: student_id,name,email,section
        layout, rows_, id_field, width = (
            _plain({"student_id": 0, "name": 1, "email": 2, "section": 3}),
            numbered,
            "student_id",
            4,
        )
    else:
        plain = {f: i for f, names in _PLAIN.items() if (i := _find(header, names)) is not None}
        layout, rows_, id_field, width = _plain(plain), numbered[1:], "student_id", len(header)
    students, errors = _students(rows_, layout, where, id_field, width)
    errors += _duplicates(students, where)
    if errors:
        errors.sort(key=lambda e: e.line or 0)
        raise ErrorList(errors)
    if not students:
        raise GradekitError("expected at least one student, got none", path=where)
    return [s for _, s in students]


Layout = Callable[[list[str]], "dict[str, str] | None"]


def _students(
    rows: list[tuple[int, list[str]]], layout: Layout, where: str, id_field: str, width: int | None
) -> tuple[list[tuple[int, Student]], list[GradekitError]]:
    """Apply a layout to every row; collect the students and one error per bad row."""
    students: list[tuple[int, Student]] = []
    errors: list[GradekitError] = []
    for n, row in rows:
        extra = [c for c in row[width:] if c.strip()] if width is not None else []
        if extra:
            message = f"expected at most {width} cells, got {len(row)} ({', '.join(map(repr, extra))} extra)"
            errors.append(GradekitError(message, path=where, line=n, field="row"))
            continue
        fields = layout(row)
        if fields is None:
            continue
        fields.setdefault("name", "")
        if not fields.get("student_id"):
            errors.append(_empty_id(where, n, fields.get("name", ""), id_field))
            continue
        students.append((n, Student(**fields)))
    return students, errors


def _canvas(header: list[str]) -> Layout:
    name, lms, sis = _find(header, ("student",)), _find(header, ("id",)), _find(header, ("sis_user_id",))
    login = _find(header, ("sis_login_id", "integration_id"))
    section, email = _find(header, ("section",)), _find(header, ("email", "email_address"))

    def layout(row: list[str]) -> dict[str, str] | None:
        full, lms_id, sis_id = _cell(row, name), _cell(row, lms), _cell(row, sis)
        if full.lower() == "points possible" or not (full or lms_id or sis_id):
            return None  # Canvas' "Points Possible" and posting-policy rows
        return {
            "student_id": sis_id or lms_id,
            "name": _first_last(full),
            "email": _cell(row, email),
            "section": _cell(row, section),
            "sis_login": _cell(row, login),
            "lms_id": lms_id,
        }

    return layout


def _moodle(header: list[str]) -> Layout:
    col = {
        "first": _find(header, ("first_name", "firstname")),
        "last": _find(header, ("surname", "last_name", "lastname")),
        "student_id": _find(header, ("id_number", "idnumber")),
        "email": _find(header, ("email_address", "email")),
        "sis_login": _find(header, ("username",)),
        "section": _find(header, ("groups", "group", "department")),
        "lms_id": _find(header, ("id", "user_id")),
    }

    def layout(row: list[str]) -> dict[str, str]:
        fields = {f: _cell(row, i) for f, i in col.items()}
        fields["name"] = f"{fields.pop('first')} {fields.pop('last')}".strip()
        fields["student_id"] = fields["student_id"] or fields["email"]  # a site without ID numbers: by email
        return fields

    return layout


def _moodle_worksheet(header: list[str]) -> Layout:
    """Moodle's offline grading worksheet: ``Identifier`` (``Participant 12345``: the participant id
    Moodle's downloads and feedback zips name), ``Full name``, ``ID number`` when the site shows it,
    ``Email address``."""
    ident, name = _find(header, ("identifier",)), _find(header, ("full_name",))
    number, email = _find(header, ("id_number", "idnumber")), _find(header, ("email_address", "email"))

    def layout(row: list[str]) -> dict[str, str] | None:
        participant = re.sub(r"\D", "", _cell(row, ident))
        if not (participant or _cell(row, name)):
            return None
        return {
            "student_id": _cell(row, number) or _cell(row, email),
            "name": _cell(row, name),
            "email": _cell(row, email),
            "lms_id": participant,
        }

    return layout


_ASSIGNMENT_COLUMN = re.compile(r"(?P<title>.*\S)\s*\((?P<id>\d+)\)")


def canvas_assignment_id(path: Path, title: str) -> str:
    """The Canvas id of the assignment called *title* in a Canvas gradebook export's header
    (``Homework 5 (123456)``; titles compared ignoring case and spacing), or ``""`` when *path* is
    not a Canvas export or has no such column. Canvas then imports grades into that assignment
    rather than offering to create a new one."""
    try:
        text, _ = decode_bytes(Path(path).read_bytes())
        header = next(csv.reader(io.StringIO(text, newline=""), delimiter=sniff_delimiter(text)), [])
    except (OSError, csv.Error):
        return ""
    keys = [header_key(c) for c in header]
    if "student" not in keys or not ("sis_user_id" in keys or "id" in keys):
        return ""
    wanted = " ".join(title.split()).casefold()
    for cell in header:
        m = _ASSIGNMENT_COLUMN.fullmatch(cell.replace("\ufeff", "").strip())
        if m and " ".join(m["title"].split()).casefold() == wanted:
            return m["id"]
    return ""


def _plain(col: dict[str, int]) -> Layout:
    def layout(row: list[str]) -> dict[str, str]:
        return {f: _cell(row, i) for f, i in col.items()}

    return layout


def _empty_id(where: str, line: int, name: str, field: str = "student_id") -> GradekitError:
    who = f" (for {name!r})" if name else ""
    return GradekitError(f"expected an id, got ''{who}", path=where, line=line, field=field)


def _duplicates(students: list[tuple[int, Student]], where: str) -> list[GradekitError]:
    first: dict[str, int] = {}
    errors = []
    for n, student in students:
        if student.student_id in first:
            errors.append(
                GradekitError(
                    f"expected a unique id, got {student.student_id!r} "
                    f"(also on row {first[student.student_id]})",
                    path=where,
                    line=n,
                    field="student_id",
                )
            )
        else:
            first[student.student_id] = n
    return errors


_RESERVED = re.compile(r"(con|prn|aux|nul|com[0-9¹²³]|lpt[0-9¹²³])(\..*)?", re.IGNORECASE)
_UNSAFE = re.compile(r"[^A-Za-z0-9_-]+")  # no dots: nothing like '..', '.x' or 'x.'


def safe_name(student_id: str, digits: int = 8) -> str:
    """A file name stem for *student_id* that stays in its folder on every OS.

    Ids made only of ``a-z 0-9 _ -`` that are not Windows device names are kept as they are;
    any other id is reduced to those characters and suffixed with the first *digits* hex digits
    of its SHA-256, so ``../x`` becomes ``x-<hash>`` and ``a/b`` and ``a_b`` stay apart. Upper
    case also takes the suffix, so ids differing only in case never meet on a case-insensitive
    file system.
    """
    clean = _UNSAFE.sub("_", student_id).strip("_-")[:48] or "student"
    if clean == student_id and not _RESERVED.fullmatch(clean) and clean == clean.lower():
        return clean
    digest = hashlib.sha256(student_id.encode("utf-8", "surrogatepass")).hexdigest()
    return f"{clean}-{digest[:digits]}"


def safe_names(student_ids: Iterable[str]) -> dict[str, str]:
    """`safe_name` for each id, lengthening the hash until no two names meet (case-folded)."""
    ids = list(dict.fromkeys(student_ids))
    for digits in (8, 16, 64):
        names = {sid: safe_name(sid, digits) for sid in ids}
        if len({n.casefold() for n in names.values()}) == len(ids):
            return names
    raise AssertionError("SHA-256 collision")  # pragma: no cover
