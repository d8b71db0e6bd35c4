"""Who may see what on the online page: access codes, the instructor's password, signed sessions, CSRF tokens.

Everything derives from one secret, a file beside the manifest (``serve.secret``, mode 0600) that
`gradekit serve` creates on its first start and never prints: a student's access code is an HMAC of
their id, so regenerating a sheet keeps it; the session cookie and the forms' CSRF tokens are signed
with keys derived from it, so several server processes that read the same file accept each other's
sessions without sharing any state.
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import json
import os
import secrets
import time
from dataclasses import dataclass
from pathlib import Path

from gradekit.errors import GradekitError

SECRET_FILE = "serve.secret"
_ALPHABET = "0123456789ABCDEFGHJKMNPQRSTVWXYZ"  # Crockford's base 32: no I, L, O, U to misread
_READ_AS = str.maketrans({"O": "0", "I": "1", "L": "1"})
CODE_LENGTH = 10  # 50 bits: guessing within the sign-in rate limit is hopeless


def secret_path(manifest: Path) -> Path:
    """The secret's file: beside the manifest (and the frozen keys)."""
    return Path(manifest).parent / SECRET_FILE


def load_secret(manifest: Path, *, create: bool = False) -> bytes:
    """The course's secret (32 random bytes, hex in the file), created with mode 0600 when *create*.

    Raises:
        GradekitError: the file is missing (and not *create*) or not a secret gradekit wrote.
    """
    path = secret_path(manifest)
    if create and not path.exists():
        text = secrets.token_hex(32) + "\n"
        try:  # O_EXCL: two servers starting at once keep the one that was written first
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:
            pass
        else:
            with os.fdopen(fd, "w") as handle:
                handle.write(text)
    try:
        text = path.read_text().strip()
    except OSError as exc:
        raise GradekitError(f"expected the course's secret (start gradekit serve once), got {exc.strerror or exc}",
                            path=str(path)) from None
    try:
        secret = bytes.fromhex(text)
    except ValueError:
        secret = b""
    if len(secret) < 16:
        raise GradekitError("expected a secret written by gradekit serve, got another text", path=str(path))
    return secret


def _mac(secret: bytes, purpose: str, message: str) -> bytes:
    return hmac.new(secret, f"{purpose}\0{message}".encode(), hashlib.sha256).digest()


def access_code(secret: bytes, student_id: str) -> str:
    """The access code printed on *student_id*'s sheet: ten characters of Crockford base 32 from an
    HMAC-SHA-256 of the id, shown as ``XXXXX-XXXXX``."""
    n = int.from_bytes(_mac(secret, "access-code", student_id)[:8], "big") >> (64 - 5 * CODE_LENGTH)
    chars = [_ALPHABET[(n >> (5 * i)) & 31] for i in reversed(range(CODE_LENGTH))]
    return "".join(chars[:5]) + "-" + "".join(chars[5:])


def code_matches(secret: bytes, student_id: str, typed: str) -> bool:
    """Whether *typed* is *student_id*'s code (case, spaces, dashes and O/0, I/L/1 forgiven)."""
    want = access_code(secret, student_id).replace("-", "")
    got = "".join(typed.split()).replace("-", "").upper().translate(_READ_AS)
    return hmac.compare_digest(want.encode(), got.encode("utf-8", "replace"))


# --- the instructor's password ----------------------------------------------------------------

_SCRYPT = {"n": 2**14, "r": 8, "p": 1}  # 16 MiB, tens of milliseconds: a sign-in, not a guessing rate


def hash_password(password: str) -> str:
    """``scrypt$n$r$p$salt$hash`` (hex) of *password* with a fresh 16-byte salt."""
    salt = secrets.token_bytes(16)
    digest = hashlib.scrypt(password.encode(), salt=salt, dklen=32, **_SCRYPT)
    return f"scrypt${_SCRYPT['n']}${_SCRYPT['r']}${_SCRYPT['p']}${salt.hex()}${digest.hex()}"


def password_matches(stored: str, password: str) -> bool:
    """Whether *password* hashes to *stored* (as `hash_password` wrote it); False for anything else."""
    try:
        kind, n, r, p, salt, digest = stored.split("$")
        if kind != "scrypt":
            return False
        got = hashlib.scrypt(password.encode(), salt=bytes.fromhex(salt), dklen=len(digest) // 2, n=int(n), r=int(r),
                             p=int(p), maxmem=2**26)
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got.hex(), digest)


# --- sessions and CSRF -------------------------------------------------------------------------

SESSION_SECONDS = 12 * 3600


@dataclass(frozen=True)
class Session:
    """Who holds a cookie: ``role`` is ``student``, ``instructor`` or ``""`` (not signed in); ``nonce``
    ties the CSRF token of every form to this cookie."""

    role: str
    student_id: str
    nonce: str
    issued: float

    def csrf(self, secret: bytes) -> str:
        """The token every form of this session carries."""
        return base64.urlsafe_b64encode(_mac(secret, "csrf", self.nonce)[:24]).decode()

    def csrf_ok(self, secret: bytes, token: str) -> bool:
        return hmac.compare_digest(self.csrf(secret).encode(), token.encode("utf-8", "replace"))


def new_session(role: str = "", student_id: str = "") -> Session:
    """A session with a fresh nonce (a new one at every sign-in: a token seen before it is worthless)."""
    return Session(role, student_id, secrets.token_urlsafe(18), time.time())


def seal(secret: bytes, session: Session) -> str:
    """The cookie value: the session as JSON, base64, and its HMAC."""
    body = base64.urlsafe_b64encode(
        json.dumps([session.role, session.student_id, session.nonce, session.issued]).encode()
    ).decode()
    sig = base64.urlsafe_b64encode(_mac(secret, "session", body)).decode()
    return f"{body}.{sig}"


def unseal(secret: bytes, cookie: str | None) -> Session | None:
    """The session of a cookie `seal` made and that is not older than `SESSION_SECONDS`; else None."""
    if not cookie or "." not in cookie:
        return None
    body, sig = cookie.rsplit(".", 1)
    want = base64.urlsafe_b64encode(_mac(secret, "session", body)).decode()
    if not hmac.compare_digest(want.encode(), sig.encode("utf-8", "replace")):
        return None
    try:
        role, student_id, nonce, issued = json.loads(base64.urlsafe_b64decode(body))
    except (ValueError, TypeError):
        return None
    if time.time() - float(issued) > SESSION_SECONDS:
        return None
    return Session(str(role), str(student_id), str(nonce), float(issued))
