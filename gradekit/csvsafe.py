"""CSV in and out without surprises: injection-safe cells, atomic writes, forgiving decoding."""

from __future__ import annotations

import codecs
import csv
import io
import os
import tempfile
from collections.abc import Iterable, Sequence
from numbers import Number
from pathlib import Path

# OWASP's list: a spreadsheet treats a cell starting with one of these as a formula.
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def safe_cell(value: object) -> str | int | float:
    """A cell value that a spreadsheet will never run as a formula.

    Text starting with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return gets a leading
    ``'``; numbers (int, float, also numpy scalars) are returned unchanged, so a negative number
    written as a number stays a number; ``None`` becomes an empty cell.

    Args:
        value: the cell value.

    Returns:
        The value to hand to `csv.writer`.
    """
    if value is None:
        return ""
    if isinstance(value, Number) and not isinstance(value, complex):
        return value  # type: ignore[return-value]
    text = str(value)
    if text.startswith(_FORMULA_START):
        return "'" + text
    return text


def atomic_write(path: Path, data: str | bytes, *, encoding: str = "utf-8") -> None:
    """Write *data* to *path* via a temporary file in the same folder and `os.replace`.

    A reader never sees a half-written file, and an interrupted run leaves the old file intact.

    Args:
        path: the destination file; its folder must exist.
        data: text (encoded with *encoding*) or bytes.
        encoding: the text encoding.
    """
    path = Path(path)
    payload = data.encode(encoding) if isinstance(data, str) else data
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(payload)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def write_csv(
    path: Path,
    header: Sequence[object],
    rows: Iterable[Sequence[object]],
    *,
    encoding: str = "utf-8",
) -> None:
    """Write a CSV atomically, every cell passed through `safe_cell`.

    Args:
        path: the destination file.
        header: the column names.
        rows: the data rows.
        encoding: the file encoding (``utf-8-sig`` adds the BOM Excel likes).
    """
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\r\n")
    writer.writerow([safe_cell(c) for c in header])
    for row in rows:
        writer.writerow([safe_cell(c) for c in row])
    atomic_write(path, buffer.getvalue(), encoding=encoding)


_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32-le"),
    (codecs.BOM_UTF32_BE, "utf-32-be"),
    (codecs.BOM_UTF8, "utf-8"),
    (codecs.BOM_UTF16_LE, "utf-16-le"),
    (codecs.BOM_UTF16_BE, "utf-16-be"),
)


def decode_bytes(data: bytes) -> tuple[str, str]:
    """Decode a text file as spreadsheets and LMSs write them; never raises.

    A BOM decides (UTF-8, UTF-16, UTF-32); otherwise strict UTF-8, then UTF-16 when every other
    byte is NUL (a BOM-less export), then cp1252, then latin-1 (which accepts every byte).

    Args:
        data: the file's bytes.

    Returns:
        The text (without BOM) and the name of the encoding used.
    """
    for bom, name in _BOMS:
        if data.startswith(bom):
            return data[len(bom) :].decode(name, errors="replace"), name
    try:
        return data.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        pass
    sample = data[:4096]
    if len(sample) >= 4 and len(sample) % 2 == 0:
        if sample[1::2].count(0) == len(sample) // 2 and sample[0::2].count(0) == 0:
            return data.decode("utf-16-le", errors="replace"), "utf-16-le"
        if sample[0::2].count(0) == len(sample) // 2 and sample[1::2].count(0) == 0:
            return data.decode("utf-16-be", errors="replace"), "utf-16-be"
    try:
        return data.decode("cp1252"), "cp1252"
    except UnicodeDecodeError:
        return data.decode("latin-1"), "latin-1"


def sniff_delimiter(text: str) -> str:
    """The delimiter of a CSV text: the most frequent of tab, ``;`` and ``,`` on its first line.

    The first non-blank line is usually the header, which holds no decimal commas; ties go to
    the comma.
    """
    first = ""
    for line in text.splitlines():
        if line.strip():
            first = line
            break
    counts = {d: first.count(d) for d in (",", ";", "\t")}
    best = max(counts, key=lambda d: (counts[d], d == ","))
    return best if counts[best] else ","
