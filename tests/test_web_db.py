"""The online page's database through the command line: a versioned schema, a password never stored in clear."""

from __future__ import annotations

import sqlite3

from test_web_helpers import cli


def test_the_schema_is_versioned_and_the_password_stored_as_an_scrypt_hash(tmp_path):
    db = tmp_path / "serve.sqlite3"
    url = f"sqlite:///{db}"
    cli("serve-passwd", "--db", url, "--password-stdin", cwd=tmp_path, stdin="a long passphrase\n")
    cli("serve-passwd", "--db", url, "--password-stdin", cwd=tmp_path, stdin="another passphrase\n")  # migrated once
    with sqlite3.connect(db) as conn:
        assert conn.execute("SELECT version FROM schema_version").fetchall() == [(1,)]
        (stored,), = conn.execute("SELECT value FROM settings WHERE name = 'instructor_password'").fetchall()
    kind, n, r, p, salt, digest = stored.split("$")
    assert (kind, n, r, p) == ("scrypt", "16384", "8", "1")
    assert (len(bytes.fromhex(salt)), len(bytes.fromhex(digest))) == (16, 32)
    assert all(b"passphrase" not in f.read_bytes() for f in tmp_path.glob("serve.sqlite3*"))  # with its WAL
    with sqlite3.connect(db) as conn:
        conn.execute("UPDATE schema_version SET version = 99")
    r = cli("serve-passwd", "--db", url, "--password-stdin", cwd=tmp_path, stdin="a long passphrase\n", check=False)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert "expected a database of schema version 1 or older, got version 99" in r.stderr


def test_a_short_password_and_a_database_that_cannot_be_reached_are_one_line_each(tmp_path):
    r = cli("serve-passwd", "--db", f"sqlite:///{tmp_path / 'x.sqlite3'}", "--password-stdin", cwd=tmp_path,
            stdin="short\n", check=False)
    assert r.returncode == 1 and "expected a password of at least 8 characters, got 5" in r.stderr
    r = cli("export", "--db", "postgresql://nobody@127.0.0.1:1/none", "--out", "x", cwd=tmp_path, check=False)
    assert r.returncode == 1 and "Traceback" not in r.stderr and "expected a database to connect to" in r.stderr
    r = cli("export", "--db", "mysql://x/y", "--out", "x", cwd=tmp_path, check=False)
    assert r.returncode == 1 and "expected a database URL postgresql://… or sqlite:///FILE, got 'mysql'" in r.stderr
