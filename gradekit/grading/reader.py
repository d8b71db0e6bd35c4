"""Read students' answer CSVs as they really arrive: any encoding, delimiter, layout or damage."""

from __future__ import annotations

import csv
import io
import math
import os
import re
import stat
import unicodedata
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from gradekit import units
from gradekit.csvsafe import decode_bytes, sniff_delimiter, unguard
from gradekit.errors import GradekitError
from gradekit.grading.lms import lms_name
from gradekit.roster import Student, header_key

MAX_BYTES = 2_000_000  # a submission of a few dozen answers is a few kB
MAX_CELL = 80  # characters of a value cell ("-1.234567e+03 lbf*in/s**2" is 25)
EXPECTED = "student_id,key,value,unit"


@dataclass(frozen=True)
class Issue:
    """Something wrong with a submission, located as ``path:line: field: message``."""

    path: str
    line: int | None
    field: str | None
    message: str

    def __str__(self) -> str:
        return GradekitError(self.message, path=self.path, line=self.line, field=self.field).message


class Answer(NamedTuple):
    """One answer as read: the raw text, and the number and unit it was parsed into.

    ``number`` is in ``unit`` as written (``unit`` empty when none was given: the key's unit is
    meant); it is None when the cell could not be read, and ``issue`` then says why.
    """

    key: str
    raw: str
    raw_unit: str
    number: float | None
    unit: str
    line: int
    field: str = "value"
    issue: str = ""

    @property
    def written(self) -> str:
        """What the student wrote, as feedback and the hand-check list show it: the cell, then its unit cell
        in brackets (``8.3 [N]``)."""
        return self.raw + (f" [{self.raw_unit}]" if self.raw_unit else "")


@dataclass(frozen=True)
class Submission:
    """What one file says for one student (a class-wide file yields several).

    ``student_id`` is a roster id, or None when the file could not be tied to a student;
    ``claimed`` then holds the ids it named. ``readable`` is False for files that gave no rows.
    ``named`` is the student the file's (LMS) name points to, if any; ``conflicts`` are the other
    roster students the file's id column names (a friend's template, a copy): the file is graded
    as ``named`` and never as any of them.
    """

    path: str
    student_id: str | None
    answers: tuple[Answer, ...] = ()
    issues: tuple[Issue, ...] = ()
    claimed: tuple[str, ...] = ()
    readable: bool = True
    mtime: float = 0.0
    class_wide: bool = False
    named: str | None = None
    conflicts: tuple[str, ...] = ()

    @property
    def by_name(self) -> bool:
        """The file's own name points to the student it is graded for."""
        return self.named is not None and self.named == self.student_id


# LMS download names. Canvas: ``lastfirst[_LATE]_<user id>_<submission id>_<uploaded name>``;
# Moodle: ``<Full Name>_<participant id>_assignsubmission_file_`` (a folder, or a prefix of the
# file name). The numbers there are the LMS's own ids, never student numbers.


def _letters(text: str) -> list[str]:
    """The words of a name, casefolded, accents and punctuation dropped."""
    plain = unicodedata.normalize("NFKD", text)
    plain = "".join(c for c in plain if not unicodedata.combining(c)).casefold()
    return [w for w in re.split(r"[^\w]+|_|\d+", plain) if w]


def _name_forms(name: str) -> set[str]:
    """How an LMS may glue a roster name into a file name: ``ivyjones``, ``jonesivy``."""
    words = _letters(name)
    if not words:
        return set()
    return {"".join(words), "".join(words[-1:] + words[:-1]), "".join(words[1:] + words[:1])}


class IdIndex:
    """Match the ids students and LMS downloads write to roster ids.

    Exact ids first, then forgiving forms a spreadsheet produces (case, ``12345.0``, lost
    leading zeros) when they are unambiguous; LMS user ids (``Student.lms_id``) in file names.
    """

    def __init__(self, students: Iterable[Student]) -> None:
        self.exact: dict[str, str] = {}
        self.ids: dict[str, str] = {}
        self.lms: dict[str, str] = {}
        loose: dict[str, set[str]] = {}
        names: dict[str, set[str]] = {}
        for s in students:
            self.exact[s.student_id] = s.student_id
            self.ids[s.student_id] = s.student_id
            for form in self._forms(s.student_id):
                loose.setdefault(form, set()).add(s.student_id)
            for form in _name_forms(s.name):
                names.setdefault(form, set()).add(s.student_id)
            if s.lms_id:
                self.exact.setdefault(s.lms_id, s.student_id)
                self.lms.setdefault(s.lms_id, s.student_id)
        self.loose = {k: next(iter(v)) for k, v in loose.items() if len(v) == 1}
        self.names = {k: next(iter(v)) for k, v in names.items() if len(v) == 1}

    @staticmethod
    def _forms(text: str) -> list[str]:
        t = text.strip().casefold()
        if re.fullmatch(r"\d+\.0+", t):
            t = t.split(".")[0]
        forms = [t]
        if t.isdigit():
            forms.append(t.lstrip("0") or "0")
        return forms

    def match(self, raw: str, *, lms: bool = True) -> str | None:
        """The roster id *raw* names (a formula guard ``'`` removed), or None.

        Args:
            raw: the cell or name part.
            lms: also accept an LMS user id (``Student.lms_id``).
        """
        text = unguard(raw.strip())
        if text in (self.exact if lms else self.ids):
            return self.exact[text]
        for form in self._forms(text):
            if form in self.loose:
                return self.loose[form]
        return None

    def from_path(self, relative: str) -> set[str]:
        """The roster students a (relative) file path points to: none, one, or several (ambiguous).

        Where an LMS put its name (Canvas, Moodle: `gradekit.grading.lms.lms_name`), only the LMS user
        id (through the roster's LMS ids) or else the student's name in it counts; a number there
        is never read as a student number. Otherwise a folder named exactly by a student id, or
        a student id standing as a word of the file name (``1001.csv``, ``1001_answers.csv``,
        ``hw5 1001.csv``).
        """
        parts = [p for p in re.split(r"[/\\]+", relative) if p]
        for part in parts:
            m = lms_name(part)
            if m:
                sid = self.lms.get(m.uid) or self.names.get("".join(_letters(m.name)))
                return {sid} if sid else set()
        found = set()
        for folder in parts[:-1]:
            sid = self.match(folder, lms=False)
            if sid:
                found.add(sid)
        stem = re.sub(r"\.[A-Za-z0-9]{1,5}$", "", parts[-1]) if parts else ""
        stem = re.sub(r"\s*\(\d+\)$", "", stem)  # a browser's copy counter: "answers (2).csv"
        words = [stem, *re.split(r"[\s_]+", stem), *re.split(r"[\s_.,()\[\]-]+", stem)]
        for word in words:
            if word.isdigit():  # a number names a student only as written: "001" is not student 1
                sid = self.ids.get(word)
            else:
                sid = self.match(word, lms=False) if word else None
            if sid:
                found.add(sid)
        return found


class KeyIndex:
    """The answer keys of the assignment, matched exactly, then case-insensitively."""

    def __init__(self, keys: Iterable[str]) -> None:
        self.keys = set(keys)
        folded: dict[str, set[str]] = {}
        for k in self.keys:
            folded.setdefault(k.strip().casefold(), set()).add(k)
        self.folded = {k: next(iter(v)) for k, v in folded.items() if len(v) == 1}

    def match(self, raw: str) -> str | None:
        """The key *raw* names, or None."""
        text = raw.strip()
        if text in self.keys:
            return text
        return self.folded.get(text.casefold())

    def sample(self) -> str:
        """A few keys for messages."""
        ordered = sorted(self.keys)
        return ", ".join(ordered[:4]) + (", …" if len(ordered) > 4 else "")


_NUM = re.compile(
    r"\s*(?P<num>[+-]?(?:\d{1,3}(?:,\d{3})+(?![\d,])(?:\.\d*)?|\d{1,3}(?:\.\d{3})+(?![\d.])(?:,\d*)?"
    r"|\d+(?:[.,]\d*)?|[.,]\d+)"
    r"(?:[eE][+-]?\d+)?)"
    r"(?:\s*[x×*·]\s*10\s*(?:\^|\*\*)\s*(?P<exp>[+-]?\d+))?\s*(?P<unit>.*?)\s*"
)
_NONFINITE = re.compile(r"[+-]?(nan|inf|infinity|∞)", re.IGNORECASE)
_PLAIN_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")  # 1.12, -3e4: no unit
_SPACES = str.maketrans({
    "\u00a0": " ", "\u2009": " ", "\u202f": " ", "\u2212": "-", "\u2013": "-", "\u3000": " ",
    # full-width digits and signs (an East Asian keyboard's input mode): 40.85
    **{chr(0xFF10 + d): str(d) for d in range(10)}, "\uff0e": ".", "\uff0c": ",", "\uff0b": "+", "\uff0d": "-",
})


def parse_value(text: str, *, decimal_comma: bool) -> tuple[float, str]:
    """Read a value cell such as ``1.12``, ``-3,5``, ``1.2e3`` or ``1120 N*mm``.

    Args:
        text: the cell.
        decimal_comma: the file's delimiter is not a comma, so ``1,12`` means 1.12 (with a
            comma delimiter a quoted ``1,120`` is ambiguous and refused).

    Returns:
        The number and the unit written after it (``""`` if none).

    Raises:
        ValueError: with the message to show (``expected a number, got 'abc'``).
    """
    if len(text) <= MAX_CELL and _PLAIN_NUMBER.fullmatch(text):  # most cells: what the general rules give
        value = float(text)
        if math.isfinite(value):
            return value, ""
    cell = text.translate(_SPACES).strip()
    if not cell:
        raise ValueError("expected a number, got a blank cell")
    if len(cell) > MAX_CELL:
        raise ValueError(f"expected a number and unit of at most {MAX_CELL} characters, got {len(cell):,}")
    m = _NUM.fullmatch(cell)
    if m is None:
        if _NONFINITE.match(cell):
            raise ValueError(f"expected a finite number, got {text.strip()!r}")
        raise ValueError(f"expected a number, got {_clip(text.strip())!r}")
    value = float(_plain(m["num"], decimal_comma, text))
    if m["exp"]:
        try:
            value *= 10.0 ** int(m["exp"][:6])
        except OverflowError:
            value = math.inf
    if not math.isfinite(value):
        raise ValueError(f"expected a finite number, got {_clip(text.strip())!r}")
    unit = m["unit"].strip()
    if len(unit) > units.MAX_LENGTH:
        raise ValueError(f"expected a unit of at most {units.MAX_LENGTH} characters, got {len(unit):,}")
    if re.match(r"[.,]?\d", unit):  # '1 120', '1.120,5': a thousands separator or two decimal marks
        raise ValueError(f"expected one number, with one decimal mark and any thousands in groups of three, got "
                         f"{_clip(text.strip())!r}")
    if unit.startswith("[") and unit.endswith("]"):
        unit = unit[1:-1].strip()
    return value, unit


_GROUPED = {",": re.compile(r"[+-]?\d{1,3}(?:,\d{3})+"), ".": re.compile(r"[+-]?\d{1,3}(?:\.\d{3})+")}


def _plain(num: str, decimal_comma: bool, text: str) -> str:
    """*num* (digits with commas and points) as Python reads a number, where its marks are unambiguous:
    both marks (``238,542.2``, ``213.830,3``): the last is the decimal mark and the other separates
    thousands in threes; one mark used several times (``1,234,567``): thousands; one comma: a decimal
    comma, unless three digits follow it in a file whose delimiter is the comma (``1,120``: 1.12 or 1120?).
    """
    cell = _clip(text.strip())
    commas, points = num.count(","), num.count(".")
    if commas and points:
        mark = "." if num.rfind(".") > num.rfind(",") else ","
        whole, fraction = num.rsplit(mark, 1)
        other = "," if mark == "." else "."
        if not _GROUPED[other].fullmatch(whole):
            raise ValueError(f"expected one number, with one decimal mark and any thousands in groups of three, "
                             f"got {cell!r}")
        return whole.replace(other, "") + "." + fraction
    if commas > 1 or points > 1:
        mark = "," if commas else "."
        if not _GROUPED[mark].fullmatch(num):
            raise ValueError(f"expected one number, with one decimal mark and any thousands in groups of three, "
                             f"got {cell!r}")
        return num.replace(mark, "")
    if commas and not decimal_comma and re.search(r",\d{3}$", num):
        raise ValueError(f"expected a number whose comma is unambiguous (write 1.12 for a decimal, 1120 for "
                         f"thousands), got {cell!r}")
    return num.replace(",", ".")


def _clip(text: str, width: int = 40) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


_ID_COLS = ("student_id", "studentid", "id", "sid", "student", "student_number", "id_number")
_KEY_COLS = ("key", "answer_key", "part", "question", "item")
_VALUE_COLS = ("value", "answer", "result", "val")
_UNIT_COLS = ("unit", "units", "unit_s")


def _col(header: list[str], names: tuple[str, ...]) -> int | None:
    for name in names:
        if name in header:
            return header.index(name)
    return None


_CONTROL = re.compile(r"[\x00-\x08\x0b\x0e-\x1f]")  # below a space, but not tab, CR, LF or form feed


def _binary(data: bytes, text: str) -> str | None:
    if data.startswith(b"PK\x03\x04"):
        return "expected a CSV text file, got a zip or Excel workbook (save it as CSV)"
    if data.startswith(b"%PDF"):
        return "expected a CSV text file, got a PDF"
    sample = text[:4096]
    control = len(_CONTROL.findall(sample))
    if "\x00" in sample or control > len(sample) // 20:
        return "expected a CSV text file, got binary data"
    return None


def read_file(
    path: Path, display: str, relative: str, ids: IdIndex, keys: KeyIndex, *, found: set[str] | None = None
) -> list[Submission]:
    """Read one submission file; never raises for any content.

    Only a regular file is opened, without following a symbolic link and without blocking (a
    FIFO or device is refused, not read), and at most `MAX_BYTES` of it are read.

    Args:
        path: the file.
        display: the path to print in messages (``sub/x.csv``).
        relative: the path below the submissions folder, searched for student ids.
        ids: the roster ids.
        keys: the assignment's answer keys.
        found: ``ids.from_path(relative)``, when the caller has it already.

    Returns:
        One `Submission` per student the file answers for (several for a class-wide file); an
        unreadable file gives one with ``readable=False`` and the reason in ``issues``; it is
        still tied to the student its name points to.
    """
    if found is None:
        found = ids.from_path(relative)
    named = next(iter(found)) if len(found) == 1 else None

    def fail(message: str, line: int | None = None, fld: str | None = "file") -> list[Submission]:
        issue = Issue(display, line, fld, message)
        return [Submission(display, named, (), (issue,), readable=False, mtime=mtime, named=named)]

    mtime = 0.0
    try:
        data, mtime = _read_regular(path)
    except _NotRegular as exc:
        return fail(f"expected a regular file, got {exc}")
    except _TooLarge as exc:
        return fail(f"expected a small CSV (under 2 MB), got {exc}")
    except OSError as exc:
        return fail(f"expected a readable file, got {exc.strerror or exc}")
    if not data.strip():
        return fail(f"expected a CSV with columns {EXPECTED}, got an empty file")
    text, _ = decode_bytes(data)
    reason = _binary(data, text)
    if reason:
        return fail(reason)
    delimiter = sniff_delimiter(text)
    try:
        rows = _rows(text, delimiter)
    except csv.Error as exc:
        return fail(f"expected a CSV file, got unreadable CSV ({exc})")
    if not rows:
        return fail(f"expected a CSV with columns {EXPECTED}, got only blank lines")
    reader = _Layout(display, found, ids, keys, delimiter, mtime)
    return reader.read(rows)


class _NotRegular(OSError):
    """A path that is a link, FIFO, device, socket or folder."""


class _TooLarge(OSError):
    """A file over `MAX_BYTES`."""


def special_kind(mode: int) -> str | None:
    """What a non-regular file is (``a symbolic link``, ``a FIFO``...), or None for a regular file."""
    kinds = (
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISDIR, "a folder"),
    )
    for test, kind in kinds:
        if test(mode):
            return kind
    return None if stat.S_ISREG(mode) else "a special file"


def _read_regular(path: Path) -> tuple[bytes, float]:
    """The bytes and mtime of a regular file, opened without following links or blocking."""
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    kind = special_kind(os.lstat(path).st_mode)
    if kind:
        raise _NotRegular(kind)
    fd = os.open(path, flags)
    try:
        info = os.fstat(fd)
        kind = special_kind(info.st_mode)
        if kind:
            raise _NotRegular(kind)
        if info.st_size > MAX_BYTES:
            raise _TooLarge(f"{info.st_size:,} bytes")
        chunks, size = [], 0
        while size <= MAX_BYTES:
            chunk = os.read(fd, MAX_BYTES + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > MAX_BYTES:
            raise _TooLarge(f"more than {MAX_BYTES:,} bytes")
        return b"".join(chunks), info.st_mtime
    finally:
        os.close(fd)


_LINE_END = re.compile(r"\r\n|\r|\n")  # what ends a row for the csv module (newline="")


def _rows(text: str, delimiter: str) -> list[tuple[int, list[str]]]:
    """Non-blank rows with the line each starts on."""
    if '"' not in text and "\x00" not in text and len(text) < csv.field_size_limit():
        # No quotes, so no cell spans lines or holds the delimiter: each line is a row, split at
        # the delimiter, as the csv module reads it (most files; the module takes several times longer).
        rows = []
        for line, row in enumerate(_LINE_END.split(text), 1):
            cells = [c.strip() for c in row.split(delimiter)]
            if any(cells):
                rows.append((line, cells))
        return rows
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter, skipinitialspace=True)
    rows = []
    start = 1
    for row in reader:
        cells = [c.strip() for c in row]
        if any(cells):
            rows.append((start, cells))
        start = reader.line_num + 1
    return rows


@dataclass
class _Draft:
    """A submission being assembled."""

    answers: dict[str, Answer] = field(default_factory=dict)
    issues: list[Issue] = field(default_factory=list)
    claimed: set[str] = field(default_factory=set)
    conflicts: set[str] = field(default_factory=set)


class _Layout:
    """Work out the file's layout (long, wide, headerless) and read its rows."""

    def __init__(
        self, display: str, from_name: set[str], ids: IdIndex, keys: KeyIndex, delimiter: str, mtime: float
    ) -> None:
        self.display = display
        self.ids = ids
        self.keys = keys
        self.delimiter = delimiter
        self.mtime = mtime
        self.from_name = from_name  # the roster students the file's path points to

    @property
    def named(self) -> str | None:
        """The student the file's name points to (None: none, or several)."""
        return next(iter(self.from_name)) if len(self.from_name) == 1 else None

    def conflict(self, draft: _Draft, others: Iterable[str]) -> None:
        """Record roster students named inside the file but not by its name (the file is not theirs)."""
        others = sorted(set(others) - {self.named, None})
        if not others:
            return
        draft.conflicts.update(others)
        listed = ", ".join(map(repr, others))
        draft.issues.append(
            self.issue(
                None,
                "student_id",
                f"expected {self.named!r} (the file name's student), got rows for {listed}; graded as "
                f"{self.named!r} only, and never as {listed}",
            )
        )

    def issue(self, line: int | None, fld: str | None, message: str) -> Issue:
        return Issue(self.display, line, fld, message)

    def read(self, rows: list[tuple[int, list[str]]]) -> list[Submission]:
        header_line, header_cells = rows[0]
        header = [header_key(c) for c in header_cells]
        id_col = _col(header, _ID_COLS)
        key_col = _col(header, _KEY_COLS)
        value_col = _col(header, _VALUE_COLS)
        if key_col is not None and value_col is not None:
            unit_col = _col(header, _UNIT_COLS)
            return self._long(rows[1:], id_col, key_col, value_col, unit_col, len(header))
        wide: dict[int, str] = {}
        repeated: list[Issue] = []
        first: dict[str, int] = {}
        for i, cell in enumerate(header_cells):
            key = self.keys.match(cell)
            if key is not None and key in first:
                repeated.append(self.issue(rows[0][0], cell, f"expected each key once, got {key!r} again (first in "
                                                             f"column {first[key] + 1}; this column is ignored)"))
            elif key is not None:
                first[key] = i
                wide[i] = key
        if len(wide) >= 2 or (wide and id_col is not None):
            return self._wide(rows[1:], id_col, wide, header_cells, repeated)
        # No header: find the column holding keys in the first row.
        for i, cell in enumerate(header_cells):
            if self.keys.match(cell) is not None and i + 1 < len(header_cells):
                id_pos = i - 1 if i > 0 else None
                unit_pos = i + 2 if i + 2 < len(header_cells) else None
                width = max(len(header_cells), 4)
                return self._long(rows, id_pos, i, i + 1, unit_pos, width)
        shown = _clip(self.delimiter.join(header_cells), 60)
        issue = self.issue(header_line, "header", f"expected a header row {EXPECTED}, got {shown!r}")
        return self._finish({self.named: _Draft(issues=[issue])}, readable=False)

    def _long(
        self,
        rows: list[tuple[int, list[str]]],
        id_col: int | None,
        key_col: int,
        value_col: int,
        unit_col: int | None,
        width: int,
    ) -> list[Submission]:
        drafts: dict[str | None, _Draft] = {}
        row_ids: list[tuple[int, str, str | None]] = []  # line, raw id, roster id
        parsed: list[tuple[int, str | None, Answer | Issue]] = []
        matched: dict[str, str | None] = {"": None}  # the id cell repeats on every row
        for line, row in rows:
            raw_id = row[id_col] if id_col is not None and id_col < len(row) else ""
            sid = matched[raw_id] if raw_id in matched else matched.setdefault(raw_id, self.ids.match(raw_id))
            row_ids.append((line, raw_id, sid))
            if len(row) > width and any(row[width:]):  # text beyond the layout's cells
                hint = ""
                if self.delimiter == ",":
                    hint = " (a decimal comma? write 1.12, or use ';' between columns)"
                msg = f"expected {width} cells, got {len(row)}{hint}"
                parsed.append((line, sid, self.issue(line, "row", msg)))
                continue
            parsed.append((line, sid, self._answer(line, row, key_col, value_col, unit_col)))
        owners = self._owners(row_ids, drafts)
        for (line, _sid, item), owner in zip(parsed, owners, strict=True):
            draft = drafts.get(owner)
            if draft is None:
                draft = drafts[owner] = _Draft()
            if isinstance(item, Issue):
                draft.issues.append(item)
            elif item.key in draft.answers:
                first = draft.answers[item.key].line
                draft.issues.append(
                    self.issue(
                        line,
                        "key",
                        f"expected each key once, got {item.key!r} again "
                        f"(first on line {first}; this row is ignored)",
                    )
                )
            else:
                draft.answers[item.key] = item
        return self._finish(drafts)

    def _owners(
        self, row_ids: list[tuple[int, str, str | None]], drafts: dict[str | None, _Draft]
    ) -> list[str | None]:
        """Decide which student each row belongs to: the file name's student first, then the column.

        A file whose name points to a student is that student's alone: rows naming another
        roster student are a conflict (reported), never that other student's submission.
        """
        known = list(dict.fromkeys(sid for _, _, sid in row_ids if sid))
        owner = self.named
        if owner is None and len(known) >= 2:  # a class-wide long file
            owners = []
            for line, raw, sid in row_ids:
                owners.append(sid)
                if sid is None:
                    drafts.setdefault(None, _Draft()).claimed.add(raw)
                    if not raw:
                        drafts[None].issues.append(
                            self.issue(line, "student_id", "expected a student id, got a blank cell")
                        )
            return owners
        if owner is None and len(known) == 1:
            owner = known[0]
        if owner is None and len(self.from_name) > 1:
            names = ", ".join(sorted(self.from_name))
            drafts.setdefault(None, _Draft()).issues.append(
                self.issue(None, "file", f"expected one student in the file name, got {names}")
            )
        draft = drafts.setdefault(owner, _Draft())
        if owner is not None and owner == self.named:
            self.conflict(draft, known)
        wrong = [(line, raw) for line, raw, sid in row_ids if raw and sid is None]
        for line, raw in wrong[:3]:
            draft.claimed.add(raw)
            if owner is not None:
                draft.issues.append(
                    self.issue(
                        line,
                        "student_id",
                        f"expected {owner!r}, got {_clip(raw)!r} (graded as {owner!r})",
                    )
                )
        for _, raw in wrong[3:]:
            draft.claimed.add(raw)
        return [owner] * len(row_ids)

    def _answer(
        self, line: int, row: list[str], key_col: int, value_col: int, unit_col: int | None
    ) -> Answer | Issue:
        raw_key = row[key_col] if key_col < len(row) else ""
        if not raw_key:
            return self.issue(line, "key", f"expected a key such as {self.keys.sample()}, got a blank cell")
        key = self.keys.match(raw_key)
        if key is None:
            return self.issue(
                line, "key", f"expected a key such as {self.keys.sample()}, got {_clip(raw_key)!r}"
            )
        raw = row[value_col] if value_col < len(row) else ""
        raw_unit = row[unit_col] if unit_col is not None and unit_col < len(row) else ""
        return self._cell(key, raw, raw_unit, line)

    def _cell(self, key: str, raw: str, raw_unit: str, line: int) -> Answer:
        if len(raw_unit) > units.MAX_LENGTH:
            message = f"expected a unit of at most {units.MAX_LENGTH} characters, got {len(raw_unit):,}"
            return Answer(key, raw[:MAX_CELL], raw_unit[: units.MAX_LENGTH] + "…", None, "", line, "unit", message)
        try:
            number, unit = parse_value(raw, decimal_comma=self.delimiter != ",")
        except ValueError as exc:
            return Answer(key, raw, raw_unit, None, "", line, "value", str(exc))
        return Answer(key, raw, raw_unit, number, unit or raw_unit, line, "value" if unit else "unit")

    def _wide(
        self,
        rows: list[tuple[int, list[str]]],
        id_col: int | None,
        wide: dict[int, str],
        header: list[str],
        repeated: list[Issue],
    ) -> list[Submission]:
        drafts: dict[str | None, _Draft] = {}
        named = self.named
        if named is not None:  # the file name's student only: their row, or the file's only row
            row_sids = [self.ids.match(r[id_col]) if id_col is not None and id_col < len(r) else None for _, r in rows]
            mine = [i for i, sid in enumerate(row_sids) if sid == named]
            pick = mine[0] if mine else 0 if len(rows) == 1 else None
            draft = drafts.setdefault(named, _Draft())
            self.conflict(draft, (sid for sid in row_sids if sid))
            if pick is not None:
                line, row = rows[pick]
                for i, key in wide.items():
                    raw = row[i] if i < len(row) else ""
                    draft.answers[key] = self._cell(key, raw, "", line)._replace(field=header[i])
            draft.issues.extend(repeated)
            return self._finish(drafts)
        class_wide = len(rows) > 1
        for line, row in rows:
            raw_id = row[id_col] if id_col is not None and id_col < len(row) else ""
            sid = self.ids.match(raw_id) if raw_id else None
            if sid is not None and sid in drafts:
                drafts[sid].issues.append(
                    self.issue(line, "student_id", f"expected one row per student, got {sid!r} again")
                )
                continue
            draft = drafts.setdefault(sid, _Draft())
            if sid is None:
                draft.claimed.add(raw_id)
                if not raw_id:
                    draft.issues.append(
                        self.issue(line, "student_id", "expected a student id, got a blank cell")
                    )
                continue
            for i, key in wide.items():
                raw = row[i] if i < len(row) else ""
                draft.answers[key] = self._cell(key, raw, "", line)._replace(field=header[i])
            draft.issues.extend(repeated)
        return self._finish(drafts, class_wide=class_wide)

    def _finish(
        self, drafts: dict[str | None, _Draft], readable: bool = True, class_wide: bool = False
    ) -> list[Submission]:
        if not drafts:  # a header and nothing below it
            issue = self.issue(None, "file", "expected answer rows below the header, got none")
            drafts, readable = {self.named: _Draft(issues=[issue])}, False
        return [
            Submission(
                path=self.display,
                student_id=sid,
                answers=tuple(d.answers.values()),
                issues=tuple(d.issues),
                claimed=tuple(sorted(c for c in d.claimed if c)),
                readable=readable,
                mtime=self.mtime,
                class_wide=class_wide or len(drafts) > 1,
                named=self.named,
                conflicts=tuple(sorted(d.conflicts)),
            )
            for sid, d in drafts.items()
        ]
