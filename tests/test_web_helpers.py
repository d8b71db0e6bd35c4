"""What the online page's tests share: a generated class, a server started on a free loopback port,
a throwaway PostgreSQL cluster, and the real chromium driven by Playwright. (No tests here.)"""

from __future__ import annotations

import contextlib
import csv
import glob
import io
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
PROBLEM = "s002-fourbar-120lb"


def cli(*args: str, cwd: Path, stdin: str | None = None, check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-m", "gradekit", *args], cwd=cwd, capture_output=True, text=True,
                       input=stdin, timeout=300)
    if check and r.returncode != 0:
        raise AssertionError(f"gradekit {' '.join(args)} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}")
    return r


def make_class(folder: Path, online: str, students: int = 3) -> Path:
    """A class of *students* with one problem, its sheets and frozen keys in folder/gen (returns *folder*)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "hw.yaml").write_text(
        f'title: "HW online"\ncourse: MEG373\nsalt: "web-test"\nproblems:\n  - {{id: {PROBLEM}, points: 10}}\n'
        f"online: {online}\n", encoding="utf-8")
    names = ["Ada Lovelace", "Bob <b>Tables</b>", "Chen Wei", "Dana Scully"]
    rows = "".join(f"{1001 + i},{names[i % len(names)]}\n" for i in range(students))
    (folder / "roster.csv").write_text("student_id,name\n" + rows, encoding="utf-8")
    cli("generate", "hw.yaml", "--roster", "roster.csv", "--out", "gen", "--no-keys", cwd=folder)
    return folder


def key_rows(folder: Path, student: str) -> list[dict]:
    """The student's rows of gen/key.csv (the instructor's key: what a right answer is)."""
    with open(folder / "gen" / "key.csv", newline="", encoding="utf-8") as f:
        return [r for r in csv.DictReader(f) if r["student_id"] == student]


def access_codes(folder: Path) -> dict[str, str]:
    """Every student's access code as their generated sheet prints it (read back from the PDF), checked
    against what `gradekit serve-codes` writes for the instructor."""
    import re

    from pypdf import PdfReader

    printed = {}
    for pdf in sorted((folder / "gen" / "students").glob("*/assignment.pdf")):
        text = "".join(page.extract_text() for page in PdfReader(pdf).pages[:1])
        sid = re.search(r"Student ID:\s*(\S+)", text)[1]
        printed[sid] = re.search(r"code\s+([0-9A-Z]{5}-[0-9A-Z]{5})", text)[1]
    cli("serve-codes", "--roster", "roster.csv", "--manifest", "gen/manifest.json", "--out", "codes.csv", cwd=folder)
    with open(folder / "codes.csv", newline="", encoding="utf-8") as f:
        assert printed == {r["student_id"]: r["access_code"] for r in csv.DictReader(f)}
    return printed


def answers_csv(folder: Path, student: str, values: dict[str, str]) -> str:
    """The student's answers.csv template that generate wrote, with *values* filled in."""
    text = (folder / "gen" / "students" / student / "answers.csv").read_text(encoding="utf-8")
    rows = list(csv.reader(io.StringIO(text)))
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\r\n")
    w.writerow(rows[0])
    for sid, key, value, unit in rows[1:]:
        w.writerow([sid, key, values.get(key, value), unit])
    return out.getvalue()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """`gradekit serve` in a child process on 127.0.0.1 and a free port."""

    def __init__(self, folder: Path, *extra: str, assignment: str = "hw.yaml") -> None:
        self.folder, self.extra, self.assignment = folder, extra, assignment
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.proc: subprocess.Popen | None = None

    def start(self) -> Server:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "gradekit", "serve", self.assignment, "--roster", "roster.csv", "--manifest",
             "gen/manifest.json", "--port", str(self.port), *self.extra],
            cwd=self.folder, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise AssertionError(f"gradekit serve ended: {self.proc.stdout.read()}")
            try:
                with urllib.request.urlopen(self.url + "/signin", timeout=2):
                    return self
            except OSError:
                time.sleep(0.1)
        raise AssertionError("gradekit serve did not answer within 60 s")

    def stop(self, kill: bool = False) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL if kill else signal.SIGTERM)
            self.proc.wait(timeout=30)
        self.proc = None

    def __enter__(self) -> Server:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def postgres_bin() -> Path:
    """Debian's PostgreSQL programs (the newest installed version)."""
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"), key=lambda p: int(Path(p).parts[4]))
    if not found:
        raise AssertionError("expected Debian's postgresql package (.ci/run installs it), got no initdb")
    return Path(found[-1]).parent


@contextlib.contextmanager
def postgres_cluster():
    """A throwaway PostgreSQL cluster in a temporary folder, on 127.0.0.1 and a free port; yields its URL.

    PostgreSQL refuses to run as root: as root the cluster belongs to the unprivileged ``nobody`` and its
    programs run as that user (setpriv), in a folder made for it."""
    bin_ = postgres_bin()
    root = Path(tempfile.mkdtemp(prefix="gradekit-pg-"))
    data, port = root / "data", free_port()
    as_user: list[str] = []
    if os.geteuid() == 0:
        import pwd

        nobody = pwd.getpwnam("nobody")
        os.chown(root, nobody.pw_uid, nobody.pw_gid)
        as_user = ["setpriv", f"--reuid={nobody.pw_uid}", f"--regid={nobody.pw_gid}", "--clear-groups"]

    def run(*args: str) -> None:
        r = subprocess.run([*as_user, *args], capture_output=True, text=True, timeout=120, cwd=root)
        if r.returncode != 0:
            raise AssertionError(f"{args[0]} failed: {r.stdout}\n{r.stderr}")

    run(str(bin_ / "initdb"), "-D", str(data), "-U", "postgres", "--auth=trust", "--no-sync", "-E", "UTF8")
    run(str(bin_ / "pg_ctl"), "-D", str(data), "-l", str(root / "log"), "-w", "-o",
        f"-c listen_addresses=127.0.0.1 -c port={port} -c unix_socket_directories={root} -c fsync=on "
        "-c max_connections=200", "start")
    try:
        yield f"postgresql://postgres@127.0.0.1:{port}/postgres"
    finally:
        subprocess.run([*as_user, str(bin_ / "pg_ctl"), "-D", str(data), "-m", "immediate", "stop"],
                       capture_output=True, timeout=60, cwd=root)
        shutil.rmtree(root, ignore_errors=True)


@contextlib.contextmanager
def browser():
    """Debian's chromium, headless, driven by Playwright."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()
