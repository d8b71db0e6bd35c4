"""CSV in and out without surprises: injection-safe cells, atomic writes and output folders, forgiving decoding."""

from __future__ import annotations

import codecs
import contextlib
import csv
import errno
import glob
import io
import logging
import os
import re
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterable, Sequence
from numbers import Number
from pathlib import Path

from gradekit.errors import GradekitError

log = logging.getLogger("gradekit")

# OWASP's list: a spreadsheet treats a cell starting with one of these as a formula.
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


# Text that a spreadsheet reads as a plain number: it computes nothing, so it needs no guard, and an
# id such as "-1007" or "+2519" then reads back the same everywhere (grader, Canvas, Moodle).
_PLAIN_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


def safe_cell(value: object) -> str | int | float:
    """A cell value that a spreadsheet will never run as a formula.

    Text starting with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return gets a leading
    ``'`` (which `unguard` removes again when gradekit reads the cell back), unless it is a plain
    signed number such as ``-1007``; numbers (int, float, also numpy scalars) are returned
    unchanged, so a negative number written as a number stays a number; ``None`` becomes an
    empty cell.

    Args:
        value: the cell value.

    Returns:
        The value to hand to `csv.writer`.
    """
    kind = type(value)
    if kind is str:  # most cells, as below without the abstract class check
        return "'" + value if value.startswith(_FORMULA_START) and not _PLAIN_NUMBER.fullmatch(value) else value
    if kind is int or kind is float:
        return value
    if value is None:
        return ""
    if isinstance(value, Number) and not isinstance(value, complex):
        return value  # type: ignore[return-value]
    text = str(value)
    if text.startswith(_FORMULA_START) and not _PLAIN_NUMBER.fullmatch(text):
        return "'" + text
    return text


def unguard(cell: str) -> str:
    """The text `safe_cell` guarded: ``'=x`` -> ``=x``; any other cell as it is."""
    if cell.startswith("'") and cell[1:].startswith(_FORMULA_START):
        return cell[1:]
    return cell


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


def write_staged(path: str | Path, data: str | bytes, *, encoding: str = "utf-8") -> None:
    """Write *data* to *path* in place, for a file inside a `StagedFolder`'s staging folder.

    Nothing there is visible until `StagedFolder.commit` moves it in, so the temporary file and
    rename of `atomic_write` would only add work (thousands of feedback files per class). The
    file is private to its owner (mode 0600), as `atomic_write`'s are.
    """
    payload = data.encode(encoding) if isinstance(data, str) else data
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_BINARY", 0), 0o600)
    try:
        view = memoryview(payload)
        while view:
            view = view[os.write(fd, view):]
    finally:
        os.close(fd)


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

    A BOM decides (UTF-8, UTF-16, UTF-32); otherwise UTF-16 when nearly every other byte is NUL
    (a BOM-less export), then strict UTF-8, then cp1252, then latin-1 (which accepts every byte).

    Args:
        data: the file's bytes.

    Returns:
        The text (without BOM) and the name of the encoding used.
    """
    for bom, name in _BOMS:
        if data.startswith(bom):
            return data[len(bom) :].decode(name, errors="replace"), name
    utf16 = _utf16(data)
    if utf16:
        return data.decode(utf16, errors="replace"), utf16
    try:
        return data.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        pass
    try:
        return data.decode("cp1252"), "cp1252"
    except UnicodeDecodeError:
        return data.decode("latin-1"), "latin-1"


def _utf16(data: bytes) -> str | None:
    """``utf-16-le``/``-be`` for BOM-less UTF-16 text (checked before UTF-8, which NULs also satisfy).

    Text of a CSV is mostly ASCII, so in UTF-16 nearly every other byte is NUL (and the others
    hardly ever are); a few non-Latin characters (names) do not spoil the pattern.
    """
    sample = data[:4096]
    half = len(sample) // 2
    if half < 2:
        return None
    sample = sample[: 2 * half]
    odd, even = sample[1::2].count(0), sample[0::2].count(0)
    if odd >= 0.7 * half and even <= 0.05 * half:
        return "utf-16-le"
    if even >= 0.7 * half and odd <= 0.05 * half:
        return "utf-16-be"
    return None


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


class StagedFolder:
    """A run's outputs built in a hidden folder beside OUT and moved into place only when complete.

    Use as ``with StagedFolder(out, ".gradekit-output") as stage: write below stage.root; then
    stage.commit()``. OUT is created, and locked for the run: a second run on the same folder is
    refused with a `GradekitError` while the first is working (an advisory ``flock`` on the folder
    itself, which the system drops with the process, so a killed run never leaves it stuck). The
    staging folder ``.<name>.partial-*`` is made beside OUT, on OUT's file system; when OUT is a mount
    point (another disk, a USB stick, a container volume) or its parent cannot be written, it is made
    inside OUT instead (``.gradekit.partial-*``), and a move the system still refuses across devices (a
    bind mount) is done by copying. Staging folders that a killed run left (in either place) are
    removed once the lock is taken, and logged; `removed` names them.

    An exception or Ctrl-C before `commit` removes the staging folder and leaves OUT exactly as the
    previous run left it (and no OUT at all when this run made it). `commit` moves every file in
    with Ctrl-C held back (POSIX), writes the list of files it owns to OUT/*listing*, and deletes
    the files the previous run listed that this run did not write (e.g. the feedback of a student
    no longer on the roster); files it never listed (a user's own) are never touched, and a staged
    file that would replace one of them is refused before anything moves. Should the commit itself
    be cut short (power loss), ``OUT/INCOMPLETE.txt`` says so until a later run completes.
    Anything the file system refuses (a full disk, a read-only folder) is a `GradekitError` naming
    the file.
    """

    INCOMPLETE = "INCOMPLETE.txt"
    PARTIAL = ".gradekit.partial-"  # the staging folders' names inside OUT

    def __init__(self, out: Path, listing: str, *, merge: bool = False) -> None:
        self.out = Path(out)
        self.listing = listing
        self.merge = merge  # keep the previous run's files (a partial re-run)
        self.removed: list[Path] = []
        self._made = False
        self._lock = None

    def __enter__(self) -> StagedFolder:
        """OUT made and locked, stale staging folders removed, this run's staging folder made. Done
        here, not in the constructor: a Ctrl-C that arrives once the folder exists is then inside the
        ``with`` block, whose exit removes it."""
        made = not os.path.lexists(self.out)
        with os_errors(self.out):
            self.out.mkdir(parents=True, exist_ok=True)
        self._made = made
        self._lock = _lock(self.out)
        root = None
        try:
            with _SigintHeld():  # a Ctrl-C while the staging folder is made arrives below, with `root` known
                self.removed = self._remove_stale()
                root = self._make_root()
            if self.removed:
                names = ", ".join(p.name for p in self.removed)
                log.warning("warning: removed %d staging folder(s) an interrupted run left in %s: %s",
                            len(self.removed), self.out, names)
            self.root = root
        except BaseException:
            if root is not None:
                shutil.rmtree(root, ignore_errors=True)
            self._release()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        # a Ctrl-C held back until now (by `commit`) must not cut the clean-up short; one that still
        # arrives first leaves the staging folder to the next run, which removes it
        with _SigintHeld():
            shutil.rmtree(self.root, ignore_errors=True)
            self._release()

    def _release(self) -> None:
        """Give the folder back: OUT goes again when this run made it and left nothing in it."""
        if self._made:
            try:
                self.out.rmdir()
            except OSError:
                pass
        if self._lock is not None:
            os.close(self._lock)
            self._lock = None

    def _make_root(self) -> Path:
        """The staging folder: beside OUT when that is OUT's file system, else inside OUT."""
        parent = self.out.resolve().parent
        try:
            if not os.path.ismount(self.out) and os.stat(parent).st_dev == os.stat(self.out).st_dev:
                return Path(tempfile.mkdtemp(prefix=self._beside(), dir=parent))
        except OSError:  # a parent that cannot be written (a mount point under a read-only folder)
            pass
        with os_errors(self.out):
            return Path(tempfile.mkdtemp(prefix=self.PARTIAL, dir=self.out))

    def _beside(self) -> str:
        return f".{self.out.resolve().name}.partial-"

    def _remove_stale(self) -> list[Path]:
        """The staging folders of interrupted runs, removed (the lock says no run is using them)."""
        stale = [p for p in self.out.glob(self.PARTIAL + "*") if p.is_dir() and not p.is_symlink()]
        stale += [p for p in self.out.resolve().parent.glob(glob.escape(self._beside()) + "*")
                  if p.is_dir() and not p.is_symlink()]
        for p in stale:
            shutil.rmtree(p, ignore_errors=True)
        return sorted(stale)

    def previous(self) -> list[str]:
        """The relative paths the previous run listed (empty when there is no listing)."""
        try:
            text = (self.out / self.listing).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            return []
        return [ln for ln in text.splitlines()[1:] if ln and not ln.startswith("#")]

    def _staged(self) -> tuple[list[str], list[str]]:
        """The staged regular files (``/``-separated, relative), and the folders holding only
        regular files and folders like themselves (shallowest first), which may move in whole."""
        files: list[str] = []
        whole: list[str] = []

        def walk(folder: str, rel: str) -> bool:
            plain, empty = True, True
            with os.scandir(folder) as entries:
                for entry in entries:
                    empty = False
                    if entry.is_dir(follow_symlinks=False):
                        plain = walk(entry.path, f"{rel}{entry.name}/") and plain
                    elif entry.is_file(follow_symlinks=False):
                        files.append(f"{rel}{entry.name}")
                    else:  # a symbolic link or special file: never moved
                        plain = False
            if plain and not empty and rel:
                whole.append(rel[:-1])
            return plain and not empty

        walk(str(self.root), "")
        return files, sorted(whole, key=lambda d: d.count("/"))

    def commit(self, header: str, extra_previous: Sequence[str] = (), retain: Sequence[str] = ()) -> list[Path]:
        """Move every staged file into OUT; return their final paths (see the class docstring).

        Args:
            header: the listing's first line (what wrote the folder).
            extra_previous: relative paths to treat as the previous run's even when unlisted
                (outputs of a version of gradekit that wrote no listing).
            retain: prefixes of the previous run's paths to keep even though this run did not
                write them (outputs this run was asked to leave alone).

        Raises:
            GradekitError: a staged file would replace a file no gradekit run listed (a user's), or
                the file system refused a write (the file named).
        """
        files, whole = self._staged()
        staged = sorted(files)
        old = list(dict.fromkeys([*self.previous(), *extra_previous]))
        # folders OUT does not have yet move in with one rename (thousands of feedback files)
        fresh = [d for d in whole if not os.path.lexists(self.out / d)]
        self._refuse_foreign(staged, set(old), set(fresh))
        with _SigintHeld(), os_errors(self.out):
            note = "gradekit was interrupted while writing this folder: its files may mix two runs. Run it again.\n"
            atomic_write(self.out / self.INCOMPLETE, note)
            moved: set[str] = set()
            for d in fresh:  # shallowest first: a folder inside one that moved went with it
                if not _under(d, moved) and _rename(self.root / d, self.out / d):
                    moved.add(d)
            made: set[str] = set()
            for rel in staged:
                folder, _, _ = rel.rpartition("/")
                if _under(rel, moved):
                    continue
                if folder not in made:
                    (self.out / folder).mkdir(parents=True, exist_ok=True)
                    made.add(folder)
                _move(self.root / rel, self.out / rel)
            keep = set(staged)
            kept = tuple(retain) if not self.merge else ("",)
            keep |= {rel for rel in old if rel.startswith(kept) and (self.out / rel).is_file()}
            for rel in old:
                if rel not in keep and _inside(self.out, rel) and (self.out / rel).is_file():
                    (self.out / rel).unlink()
                    _remove_empty(self.out, Path(rel).parent)
            listing = "\n".join([header, *sorted(keep)]) + "\n"
            atomic_write(self.out / self.listing, listing)
            (self.out / self.INCOMPLETE).unlink()
        return [self.out / rel for rel in staged]

    def _refuse_foreign(self, staged: list[str], old: set[str], fresh: set[str]) -> None:
        """Refuse to replace a file of OUT that no run listed (a user's), unless the last commit was cut
        short (its files were moved in before its listing was written)."""
        if os.path.lexists(self.out / self.INCOMPLETE):
            return
        for rel in staged:
            if rel in old or _under(rel, fresh):
                continue
            if os.path.lexists(self.out / rel):
                raise GradekitError(
                    f"expected a file gradekit wrote (listed in {self.listing}), got one it did not write; "
                    "move it away or choose another output folder",
                    path=str(self.out / rel),
                )


def _lock(out: Path) -> int | None:
    """An exclusive advisory lock on the folder *out* (its open descriptor), or None where the system
    has no ``flock`` (Windows) or the file system takes none (some network mounts): run unlocked.

    Refused at once, never waited for. The lock belongs to the open folder, so the system drops it when
    the process ends, however it ends. A run that made OUT removes it again when it fails; should that
    happen between our opening and locking the folder, the lock is taken again on the new folder."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        return None
    for _ in range(5):
        with os_errors(out):
            out.mkdir(parents=True, exist_ok=True)
            fd = os.open(out, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise GradekitError(
                "expected a folder no other gradekit run is writing, got one in use (another generate or grade "
                "is running on it); wait for it to end or choose another output folder",
                path=str(out),
            ) from None
        except OSError:
            return fd  # no locks on this file system
        try:
            here, held = os.stat(out), os.fstat(fd)
            if (here.st_dev, here.st_ino) == (held.st_dev, held.st_ino):
                return fd
        except OSError:
            pass
        os.close(fd)
    raise GradekitError("expected a folder that stays in place, got one removed again and again", path=str(out))


def _rename(src: Path, dst: Path) -> bool:
    """Move the folder *src* to *dst* (which does not exist) by one rename; False when the system will
    not rename across devices (a mount inside OUT): its files are then moved one by one."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.replace(src, dst)
    except OSError as exc:
        if exc.errno != errno.EXDEV:
            raise
        return False
    return True


def _move(src: Path, dst: Path) -> None:
    """Move the file *src* over *dst*: a rename, or across devices a copy beside *dst* renamed over it
    (a reader never sees half a file either way)."""
    try:
        os.replace(src, dst)
        return
    except OSError as exc:
        if exc.errno != errno.EXDEV:
            raise
    fd, tmp = tempfile.mkstemp(prefix=f".{dst.name}.", suffix=".tmp", dir=dst.parent)
    os.close(fd)
    try:
        shutil.copyfile(src, tmp)
        os.chmod(tmp, os.stat(src).st_mode & 0o7777)
        os.replace(tmp, dst)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    os.unlink(src)


@contextlib.contextmanager
def os_errors(folder: Path):
    """What the file system refuses while a run writes its output (a full disk, a read-only or missing
    folder) as a `GradekitError`: one line naming the file (*folder* when the error names none)."""
    try:
        yield
    except OSError as exc:
        if isinstance(exc, (BlockingIOError, InterruptedError)):
            raise
        where = exc.filename if exc.filename is not None else folder
        why = exc.strerror or exc.__class__.__name__
        raise GradekitError(f"expected to write the output, got {why}", path=str(where)) from None


def _under(rel: str, folders: set[str]) -> bool:
    """Whether ``/``-separated *rel* lies inside one of *folders* (looked up by its ancestors, so a
    class of folders costs no more per path than a few)."""
    i = rel.find("/")
    while i >= 0:
        if rel[:i] in folders:
            return True
        i = rel.find("/", i + 1)
    return False


def _remove_empty(folder: Path, rel: Path) -> None:
    """Remove *folder*/*rel* and its parents below *folder* while they are empty."""
    while rel.parts:
        try:
            (folder / rel).rmdir()
        except OSError:
            return
        rel = rel.parent


def _inside(folder: Path, rel: str) -> bool:
    return not Path(rel).is_absolute() and ".." not in Path(rel).parts and not os.path.islink(folder / rel)


class _SigintHeld:
    """Hold SIGINT back (delivered on exit) on the main thread of a POSIX process; else nothing."""

    def __enter__(self) -> None:
        self.held = False
        if hasattr(signal, "pthread_sigmask") and threading.current_thread() is threading.main_thread():
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
            self.held = True

    def __exit__(self, *exc) -> None:
        if self.held:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
