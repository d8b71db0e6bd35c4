"""An LMS "download all submissions" zip read as the folder it stands for, unpacked within limits.

Canvas and Moodle hand the instructor one zip of every student's files. `submissions_folder` gives
a folder for a folder as it is, and for a zip a temporary folder it unpacks the zip into (removed
afterwards). Nothing in the zip can write outside that folder (absolute names, drive letters,
``..``, links are refused), and a zip that would unpack into more than the limits allow (a zip
bomb) is refused with one line before anything large is written; the limits are checked against
the bytes actually inflated, not only against the sizes the zip declares.
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import tempfile
import time
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from gradekit.errors import GradekitError


@dataclass(frozen=True)
class Limits:
    """What one submissions zip may unpack into.

    ``total_bytes`` all files together; ``file_bytes`` one file; ``files`` how many; ``depth``
    folders above a file (Moodle's layout is one); ``ratio`` unpacked over packed size, per file
    and for the whole zip (a class's CSVs pack about 3 to 10 times; a bomb thousands of times).
    """

    total_bytes: int = 1 << 30
    file_bytes: int = 64 << 20
    files: int = 20_000
    depth: int = 8
    ratio: float = 200.0


LIMITS = Limits()
_CHUNK = 1 << 16
_DRIVE = re.compile(r"^[A-Za-z]:")


def is_zip(path: Path) -> bool:
    """True when *path* is a regular file that starts as a zip does."""
    try:
        with open(path, "rb") as f:
            return stat.S_ISREG(os.fstat(f.fileno()).st_mode) and f.read(4) in (b"PK\x03\x04", b"PK\x05\x06")
    except OSError:
        return False


@contextmanager
def submissions_folder(path: Path | str, limits: Limits = LIMITS) -> Iterator[Path]:
    """The folder of submissions *path* stands for: the folder itself, or a zip unpacked into a
    temporary folder that is removed when the block ends.

    Args:
        path: a folder, or the zip an LMS's "download all submissions" gives.
        limits: what the zip may unpack into.

    Yields:
        The folder to read.

    Raises:
        GradekitError: *path* is a file but no readable zip, or the zip breaks a limit or names a
            file outside its folder (one line naming the zip, the member and the limit).
    """
    path = Path(path)
    if not path.is_file():
        yield path
        return
    if not is_zip(path):
        raise GradekitError("expected a folder of submissions or an LMS's zip of them, got a file that is no zip",
                            path=str(path))
    folder = Path(tempfile.mkdtemp(prefix="gradekit-submissions-"))
    try:
        unpack(path, folder, limits)
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def unpack(zip_path: Path, folder: Path, limits: Limits = LIMITS) -> list[Path]:
    """Unpack *zip_path* into the empty *folder* within *limits*; return the files written.

    Folders and links in the zip are not written (a link would point anywhere); every file keeps
    the time the zip records for it (grading prefers a student's newest file).
    """
    where = str(zip_path)
    try:
        archive = zipfile.ZipFile(zip_path)
    except (zipfile.BadZipFile, OSError, ValueError) as exc:
        raise GradekitError(f"expected a zip file, got one that cannot be read ({exc})", path=where) from None
    written: list[Path] = []
    with archive:
        members = [m for m in archive.infolist() if not m.is_dir() and not _is_link(m)]
        if len(members) > limits.files:
            raise GradekitError(f"expected at most {limits.files} files in the zip, got {len(members)}", path=where)
        declared = sum(m.file_size for m in members)
        packed = sum(m.compress_size for m in members)
        _check_total(where, declared, packed, limits)
        seen: set[str] = set()
        total = 0
        for m in members:
            parts = _safe_parts(where, m.filename, limits)
            key = "/".join(parts).casefold()
            if key in seen:  # the same name twice (or differing in case only): the first one stays
                continue
            seen.add(key)
            if m.file_size > limits.file_bytes:
                raise GradekitError(f"expected at most {limits.file_bytes} bytes unpacked, "
                                    f"got {m.file_size}", path=where, field=m.filename)
            target = folder.joinpath(*parts)
            total += _copy(archive, m, target, where, limits, limits.total_bytes - total)
            _check_total(where, total, packed, limits)
            try:
                stamp = time.mktime((*m.date_time, 0, 0, -1))
                os.utime(target, (stamp, stamp))
            except (OverflowError, ValueError, OSError):
                pass
            written.append(target)
    return written


def _is_link(m: zipfile.ZipInfo) -> bool:
    return stat.S_ISLNK(m.external_attr >> 16)


def _check_total(where: str, unpacked: int, packed: int, limits: Limits) -> None:
    if unpacked > limits.total_bytes:
        raise GradekitError(f"expected at most {limits.total_bytes} bytes unpacked, got {unpacked} or more "
                            "(a zip bomb?)", path=where)
    if unpacked > limits.ratio * max(packed, 1) and unpacked > _CHUNK:
        raise GradekitError(f"expected a zip that unpacks at most {limits.ratio:g} times its size, got "
                            f"{unpacked} bytes from {packed} (a zip bomb?)", path=where)


def _safe_parts(where: str, name: str, limits: Limits) -> list[str]:
    """The path parts of a member's *name*, refused when it would leave the folder."""
    text = name.replace("\\", "/")
    parts = [p for p in PurePosixPath(text).parts if p not in ("", ".")]
    bad = text.startswith("/") or _DRIVE.match(text) or "\x00" in text or not parts or any(
        p.strip(" .") == "" for p in parts)  # "..", and names Windows reads as it
    if bad:
        raise GradekitError("expected a file name inside the zip's folder, got a path that leaves it",
                            path=where, field=name)
    if len(parts) - 1 > limits.depth:
        raise GradekitError(f"expected at most {limits.depth} folders deep, got {len(parts) - 1}",
                            path=where, field=name)
    return parts


def _copy(archive: zipfile.ZipFile, m: zipfile.ZipInfo, target: Path, where: str, limits: Limits,
          room: int) -> int:
    """Inflate member *m* into *target*, counting the bytes actually inflated (a zip may declare
    sizes smaller than its data); returns them."""
    n = 0
    cap = min(limits.file_bytes, room, int(limits.ratio * max(m.compress_size, 1)) + _CHUNK)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with archive.open(m) as src, open(target, "xb") as dst:
            while chunk := src.read(_CHUNK):
                n += len(chunk)
                if n > cap:
                    message = f"expected at most {cap} bytes unpacked from {m.compress_size} packed, got more"
                    raise GradekitError(message + " (a zip bomb?)", path=where, field=m.filename)
                dst.write(chunk)
    except (zipfile.BadZipFile, OSError, EOFError, NotImplementedError, RuntimeError) as exc:
        raise GradekitError(f"expected a readable member, got {exc}", path=where, field=m.filename) from None
    return n
