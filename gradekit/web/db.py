"""The online page's database: SQLite beside the manifest by default, PostgreSQL when named; versioned schema.

SQLAlchemy Core with bound parameters throughout (no SQL is ever built from text a user sent). The
schema is a numbered list of migration steps (`MIGRATIONS`) with the version reached kept in the
one-row table ``schema_version``: a server applies the steps its database lacks when it starts,
inside one transaction under a lock, so two processes starting on one PostgreSQL migrate it once.
A handful of tables and one course's life do not call for Alembic's revision graph and autogenerate;
the steps are plain functions a reviewer reads top to bottom.

Every attempt is a row that is inserted and never updated (append-only): the current answer to a
key is the last graded attempt, the history is the table. A submission is one row with a unique
``form_id`` (a random token in the form that sent it), so a form sent twice (a reload, a retry after
a lost response) is stored once; its attempts are committed before the page acknowledges it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from pathlib import Path

from sqlalchemy import (
    Boolean,
    Column,
    Connection,
    Engine,
    Float,
    ForeignKey,
    Index,
    Integer,
    MetaData,
    QueuePool,
    String,
    Table,
    Text,
    create_engine,
    event,
    func,
    insert,
    select,
    text,
)
from sqlalchemy.exc import OperationalError

from gradekit.errors import GradekitError

DB_FILE = "serve.sqlite3"

metadata = MetaData()

schema_version = Table("schema_version", metadata, Column("version", Integer, nullable=False))

settings = Table(
    "settings", metadata,
    Column("name", String(64), primary_key=True),
    Column("value", Text, nullable=False),
)

submissions = Table(
    "submissions", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("form_id", String(64), nullable=False, unique=True),
    Column("student_id", String(200), nullable=False, index=True),
    Column("source", String(16), nullable=False),  # form | upload
    Column("received_at", Float, nullable=False),  # seconds since the epoch (UTC)
)

attempts = Table(
    "attempts", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("submission_id", Integer, ForeignKey("submissions.id"), nullable=False),
    Column("student_id", String(200), nullable=False),
    Column("answer_key", String(200), nullable=False),
    Column("value", Text, nullable=False),
    Column("unit", Text, nullable=False),
    Column("status", String(16), nullable=False),  # graded | refused
    Column("reason", Text, nullable=False),  # why refused ("" when graded)
    Column("number", Integer),  # the attempt's number for this key (graded only)
    Column("correct", Boolean),
    Column("points", Float),
    Column("received_at", Float, nullable=False),
    Index("attempts_student_key", "student_id", "answer_key", "id"),
)

sign_ins = Table(
    "sign_ins", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("who", String(200), nullable=False),  # a student id, or "instructor"
    Column("client", String(64), nullable=False),
    Column("ok", Boolean, nullable=False),
    Column("at", Float, nullable=False),
    Index("sign_ins_who_at", "who", "at"),
    Index("sign_ins_client_at", "client", "at"),
)


def _v1(conn: Connection) -> None:
    """The first schema: settings, submissions, attempts, sign-ins."""
    for table in (settings, submissions, attempts, sign_ins):
        table.create(conn)


MIGRATIONS: list[tuple[int, Callable[[Connection], None]]] = [(1, _v1)]
"""The ordered steps: (version reached, step). A new step is appended, never edited."""


def url_for(db: str | None, manifest: Path) -> str:
    """The database URL: *db* as given (``postgresql://…`` for psycopg 3), or the SQLite file beside the manifest."""
    if not db:
        return f"sqlite:///{(Path(manifest).parent / DB_FILE).resolve()}"
    if db.startswith(("postgresql://", "postgres://")):
        return "postgresql+psycopg://" + db.split("://", 1)[1]
    if db.startswith(("postgresql+psycopg://", "sqlite:///")):
        return db
    raise GradekitError(f"expected a database URL postgresql://… or sqlite:///FILE, got {db.split(':', 1)[0]!r}…",
                        field="--db")


def connect(url: str) -> Engine:
    """An engine for *url*: SQLite in WAL mode, every commit synced, each transaction taking the write
    lock at its start (BEGIN IMMEDIATE: a reader that later writes cannot deadlock another) but those
    of `reading`."""
    if url.startswith("sqlite"):
        engine = create_engine(url, connect_args={"timeout": 30, "check_same_thread": False}, poolclass=QueuePool,
                               pool_size=8, max_overflow=8, pool_timeout=120)

        @event.listens_for(engine, "connect")
        def _on_connect(dbapi, _record) -> None:  # noqa: ANN001
            dbapi.isolation_level = None  # SQLAlchemy begins the transaction itself (below)
            cur = dbapi.cursor()
            cur.execute("PRAGMA journal_mode=WAL")
            cur.execute("PRAGMA synchronous=FULL")  # an acknowledged submission survives a crash
            cur.execute("PRAGMA foreign_keys=ON")
            cur.close()

        @event.listens_for(engine, "begin")
        def _on_begin(conn) -> None:  # noqa: ANN001
            conn.exec_driver_sql("BEGIN" if conn.get_execution_options().get("reading") else "BEGIN IMMEDIATE")

        return engine
    return create_engine(url, pool_size=10, max_overflow=20, pool_recycle=3600)


def migrate(engine: Engine) -> int:
    """Bring the schema to the last version of `MIGRATIONS`; returns it.

    Raises:
        GradekitError: the database is newer than this gradekit.
    """
    last = MIGRATIONS[-1][0]
    with engine.begin() as conn:
        if conn.dialect.name == "postgresql":  # one process migrates, the others wait for it
            conn.execute(text("SELECT pg_advisory_xact_lock(7270001)"))
        schema_version.create(conn, checkfirst=True)
        found = conn.execute(select(schema_version.c.version)).scalar()
        if found is None:
            conn.execute(insert(schema_version).values(version=0))
            found = 0
        if found > last:
            raise GradekitError(f"expected a database of schema version {last} or older, got version {found} "
                                "(written by a newer gradekit)", path=engine.url.render_as_string())
        for version, step in MIGRATIONS:
            if version > found:
                step(conn)
                conn.execute(schema_version.update().values(version=version))
    return last


class Database:
    """An engine and how its transactions are taken: `reading` ones run side by side (SQLite's WAL lets
    readers go on while one writes); `writing` ones of one process queue on a lock for SQLite (each
    would otherwise wait on SQLite's own lock in its busy handler's sleeps, a convoy under load), and
    on PostgreSQL each takes an advisory lock on the student it writes for."""

    def __init__(self, url: str) -> None:
        self.engine = connect(url)
        self.sqlite = self.engine.dialect.name == "sqlite"
        self._writer = threading.Lock() if self.sqlite else None

    def reading(self):  # noqa: ANN201 (a transaction's context manager)
        """A transaction that only reads (on SQLite it takes no write lock, and its commit writes nothing)."""
        return self.engine.execution_options(reading=True).begin()

    @contextmanager
    def writing(self, student_id: str | None = None) -> Iterator[Connection]:
        """A transaction that writes; with *student_id*, no other one (of any server process) changes that
        student's attempts meanwhile (SQLite: the database's write lock; PostgreSQL: an advisory lock)."""
        with self._writer if self._writer is not None else nullcontext():
            with self.engine.begin() as conn:
                if student_id is not None and not self.sqlite:
                    conn.execute(text("SELECT pg_advisory_xact_lock(hashtext(:sid))"), {"sid": student_id})
                yield conn

    def migrate(self) -> int:
        """`migrate` this database (the first connection: a database that cannot be reached is one line).

        Raises:
            GradekitError: the database cannot be reached, or is newer than this gradekit.
        """
        try:
            return migrate(self.engine)
        except OperationalError as exc:
            reason = str(exc.orig).strip().splitlines()[0] if exc.orig is not None else str(exc)
            raise GradekitError(f"expected a database to connect to, got {reason}",
                                path=self.engine.url.render_as_string(hide_password=True)) from None

    def dispose(self) -> None:
        self.engine.dispose()


def get_setting(conn: Connection, name: str) -> str | None:
    return conn.execute(select(settings.c.value).where(settings.c.name == name)).scalar()


def put_setting(conn: Connection, name: str, value: str) -> None:
    if get_setting(conn, name) is None:
        conn.execute(insert(settings).values(name=name, value=value))
    else:
        conn.execute(settings.update().where(settings.c.name == name).values(value=value))


@dataclass(frozen=True)
class Attempt:
    """One stored attempt (a row of ``attempts``; ``id`` None: just stored, its number not read back)."""

    id: int | None
    submission_id: int
    student_id: str
    key: str
    value: str
    unit: str
    status: str
    reason: str
    number: int | None
    correct: bool | None
    points: float | None
    received_at: float


_ATTEMPT_COLUMNS = (
    attempts.c.id, attempts.c.submission_id, attempts.c.student_id, attempts.c.answer_key, attempts.c.value,
    attempts.c.unit, attempts.c.status, attempts.c.reason, attempts.c.number, attempts.c.correct, attempts.c.points,
    attempts.c.received_at,
)


def student_attempts(conn: Connection, student_id: str) -> list[Attempt]:
    """Every attempt of one student, oldest first."""
    rows = conn.execute(select(*_ATTEMPT_COLUMNS).where(attempts.c.student_id == student_id).order_by(attempts.c.id))
    return [Attempt(*row) for row in rows]


def last_attempt(conn: Connection, student_id: str) -> int | None:
    """The id of the student's latest attempt (None: none yet)."""
    return conn.execute(select(func.max(attempts.c.id)).where(attempts.c.student_id == student_id)).scalar()


def all_attempts(conn: Connection) -> list[Attempt]:
    """Every attempt of the class, oldest first."""
    return [Attempt(*row) for row in conn.execute(select(*_ATTEMPT_COLUMNS).order_by(attempts.c.id))]


def submission_by_form(conn: Connection, form_id: str) -> tuple[int, str] | None:
    """(id, student) of the submission a form sent, if it was stored."""
    query = select(submissions.c.id, submissions.c.student_id).where(submissions.c.form_id == form_id)
    row = conn.execute(query).first()
    return (row[0], row[1]) if row else None


def add_submission(conn: Connection, form_id: str, student_id: str, source: str, at: float,
                   rows: list[dict]) -> int:
    """Store a submission and its attempts (*rows*: the `attempts` columns but the ids and the time)."""
    sid = conn.execute(
        insert(submissions).values(form_id=form_id, student_id=student_id, source=source, received_at=at)
        .returning(submissions.c.id)
    ).scalar_one()
    if rows:
        conn.execute(insert(attempts), [{**r, "submission_id": sid, "student_id": student_id, "received_at": at}
                                        for r in rows])
    return sid


def count_submissions(conn: Connection) -> int:
    return conn.execute(select(func.count()).select_from(submissions)).scalar_one()


def form_ids(conn: Connection) -> list[str]:
    """Every stored submission's form id (the benchmark checks none is lost or stored twice)."""
    return list(conn.execute(select(submissions.c.form_id)).scalars())


RATE_WINDOW = 300.0  # seconds
RATE_PER_ACCOUNT = 5  # failed sign-ins to one account within the window
RATE_PER_CLIENT = 30  # failed sign-ins from one address within the window


def sign_in_allowed(conn: Connection, who: str, client: str, now: float | None = None) -> bool:
    """Whether a sign-in may be tried: fewer than `RATE_PER_ACCOUNT` failures for *who* and
    `RATE_PER_CLIENT` from *client* within the last `RATE_WINDOW` seconds (the limits hold across
    every server process, since the failures are in the database)."""
    since = (now or time.time()) - RATE_WINDOW
    failed = sign_ins.c.ok.is_(False) & (sign_ins.c.at >= since)
    mine = conn.execute(select(func.count()).select_from(sign_ins).where(failed & (sign_ins.c.who == who))).scalar()
    theirs = conn.execute(
        select(func.count()).select_from(sign_ins).where(failed & (sign_ins.c.client == client))).scalar()
    return mine < RATE_PER_ACCOUNT and theirs < RATE_PER_CLIENT


def record_sign_in(conn: Connection, who: str, client: str, ok: bool, now: float | None = None) -> None:
    conn.execute(insert(sign_ins).values(who=who[:200], client=client[:64], ok=ok, at=now or time.time()))
