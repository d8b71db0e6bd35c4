"""The online page under load: simulated students submitting their whole assignment concurrently.

A class of 300 (one problem of four answers, 3 attempts each) is generated once into
``benchmarks/out/serve-class`` (`gradekit generate --no-keys`). For each configuration a real
`gradekit serve` runs on loopback (uvicorn, one process, or two sharing PostgreSQL), and 300
simulated students, each with its own cookie jar, sign in and then, until the time is up, submit
their whole answer table again and again (a wrong value first, the key's value later, and, once
the attempts are used up, submissions whose changed answers are refused and stored as refused),
pausing a random think time between submissions (``--think``: uniform between 0 and twice it; 0
for a saturation run). Every submission carries a unique form id; the page's acknowledgement
(the stored submission's number) is recorded.

Reported per configuration: acknowledged submissions, throughput, latency of the submissions
(p50, p95, p99, max), errors, and, read back from the database after the servers stopped, the
acknowledged submissions lost (not stored), stored twice or stored under another number, and any
answer with more graded attempts than allowed (a race between concurrent requests would show here).

Run: ``python benchmarks/bench_serve.py [--duration 60] [--students 300] [--think 2]
[--only sqlite|postgresql|postgresql-2]``; the PostgreSQL runs start a throwaway cluster themselves.
Loopback only; every loop is bounded by the duration.
"""

from __future__ import annotations

import argparse
import asyncio
import csv
import json
import random
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
CLASS = ROOT / "benchmarks" / "out" / "serve-class"
sys.path.insert(0, str(ROOT / "tests"))
from test_web_helpers import Server, postgres_cluster  # noqa: E402  (the tests' server and cluster)

ASSIGNMENT = """title: "Online benchmark"
course: MEG373
salt: "bench-serve"
problems:
  - {id: s002-fourbar-120lb, points: 10}
online: {attempts: 3}
"""
_CSRF = re.compile(r'name="csrf" value="([^"]+)"')
_ACK = re.compile(r'id="receipt" data-submission="(\d+)"')


def prepare(n: int) -> None:
    """The class of *n* students, generated once (kept while its roster has *n* students)."""
    roster = CLASS / "roster.csv"
    if (CLASS / "gen" / "manifest.json").exists() and roster.exists() and \
            len(roster.read_text().splitlines()) == n + 1:
        return
    CLASS.mkdir(parents=True, exist_ok=True)
    (CLASS / "hw.yaml").write_text(ASSIGNMENT, encoding="utf-8")
    roster.write_text("student_id,name\n" + "".join(f"{200000 + i},Student {i}\n" for i in range(n)), encoding="utf-8")
    subprocess.run([sys.executable, "-m", "gradekit", "-q", "generate", "hw.yaml", "--roster", "roster.csv", "--out",
                    "gen", "--no-keys", "--jobs", "2"], cwd=CLASS, check=True)


def class_data() -> tuple[dict[str, str], dict[str, list[tuple[str, str, str]]]]:
    """Each student's access code, and their answers as (key, right value, wrong value)."""
    from gradekit.web.access import access_code, load_secret

    secret = load_secret(CLASS / "gen" / "manifest.json", create=True)
    answers: dict[str, list[tuple[str, str, str]]] = {}
    with open(CLASS / "gen" / "key.csv", newline="", encoding="utf-8") as f:
        for r in csv.DictReader(f):
            answers.setdefault(r["student_id"], []).append((r["key"], r["value"], repr(float(r["value"]) * 1.5 + 1)))
    return {sid: access_code(secret, sid) for sid in answers}, answers


async def sign_in(c: httpx.AsyncClient, sid: str, code: str, log: dict) -> str | None:
    """Sign a student in; their page's CSRF token (None: failed)."""
    try:
        page = (await c.get("/signin")).text
        r = await c.post("/signin", data={"csrf": _CSRF.search(page).group(1), "student_id": sid, "code": code},
                         follow_redirects=True)
        return _CSRF.search(r.text).group(1)
    except (httpx.HTTPError, AttributeError) as exc:
        log["errors"].append(f"sign-in {sid}: {exc!r}")
        return None


async def student(c: httpx.AsyncClient, sid: str, token: str, answers: list, deadline: float, think: float,
                  rng: random.Random, log: dict) -> None:
    """One signed-in student: submit the whole table until *deadline*."""
    n = 0

    async def pause() -> None:  # the think time, never past the deadline
        await asyncio.sleep(min(rng.uniform(0, think * 2), max(0.0, deadline - time.monotonic())))

    await pause()
    while time.monotonic() < deadline:
        n += 1
        form_id = f"{sid}-{n}"
        form = {"csrf": token, "form_id": form_id}
        for key, right, wrong in answers:  # attempt 1 wrong, then right; later ones changed again (refused)
            form[f"value:{key}"] = wrong if n == 1 else right if n == 2 else f"{right}{n}"
            form[f"unit:{key}"] = ""
        t0 = time.perf_counter()
        try:
            r = await c.post("/student/submit", data=form)
        except httpx.TransportError:  # the connection dropped: the same form again (stored once at most)
            log["resent"] += 1
            try:
                r = await c.post("/student/submit", data=form)
            except httpx.HTTPError as exc:
                log["errors"].append(f"{form_id}: {exc!r}")
                continue
        log["latency"].append(time.perf_counter() - t0)
        ack = _ACK.search(r.text) if r.status_code == 200 else None
        if ack is None:
            log["errors"].append(f"{form_id}: HTTP {r.status_code}")
        else:
            log["acknowledged"][form_id] = int(ack.group(1))
        if think:
            await pause()


async def load(urls: list[str], codes: dict, answers: dict, duration: float, think: float) -> dict:
    """Sign every student in (timed apart), then let them all submit for *duration* seconds."""
    log = {"latency": [], "acknowledged": {}, "errors": [], "resent": 0}
    rng = random.Random(373)
    ids = sorted(codes)
    limits = httpx.Limits(max_connections=1, max_keepalive_connections=1)
    clients = [httpx.AsyncClient(base_url=urls[i % len(urls)], timeout=120, limits=limits) for i in range(len(ids))]
    try:
        t0 = time.monotonic()
        tokens = await asyncio.gather(*(sign_in(c, sid, codes[sid], log) for c, sid in zip(clients, ids, strict=True)))
        log["sign_in_seconds"] = time.monotonic() - t0
        start = time.monotonic()
        deadline = start + duration
        await asyncio.gather(*(student(c, sid, token, answers[sid], deadline, think, rng, log)
                               for c, sid, token in zip(clients, ids, tokens, strict=True) if token))
        log["seconds"] = time.monotonic() - start
    finally:
        await asyncio.gather(*(c.aclose() for c in clients))
    return log


def check(db_url: str | None, log: dict, attempts: int) -> dict:
    """What the database holds of the acknowledged submissions (read after the servers stopped)."""
    from sqlalchemy import func, select

    from gradekit.web import db

    database = db.Database(db.url_for(db_url, CLASS / "gen" / "manifest.json"))
    with database.reading() as conn:
        stored = {}
        duplicated = 0
        for form_id, number in conn.execute(select(db.submissions.c.form_id, db.submissions.c.id)):
            duplicated += form_id in stored
            stored[form_id] = number
        over = conn.execute(
            select(func.count()).select_from(
                select(db.attempts.c.student_id, db.attempts.c.answer_key)
                .where(db.attempts.c.status == "graded")
                .group_by(db.attempts.c.student_id, db.attempts.c.answer_key)
                .having(func.count() > attempts).subquery())).scalar_one()
        refused = conn.execute(select(func.count()).select_from(db.attempts)
                               .where(db.attempts.c.status == "refused")).scalar_one()
    database.dispose()
    acked = log["acknowledged"]
    lost = sum(1 for f in acked if f not in stored)
    renumbered = sum(1 for f, n in acked.items() if f in stored and stored[f] != n)
    return {"stored": len(stored), "lost": lost, "duplicated": duplicated, "renumbered": renumbered,
            "over_limit": over, "refused_attempts": refused}


def run(name: str, db_url: str | None, processes: int, codes: dict, answers: dict, args) -> dict:
    db_file = CLASS / "gen" / "serve.sqlite3"
    if db_url is None:
        for suffix in ("", "-wal", "-shm"):
            Path(f"{db_file}{suffix}").unlink(missing_ok=True)
    extra = ("--db", db_url) if db_url else ()
    servers = [Server(CLASS, *extra).start() for _ in range(processes)]
    try:
        log = asyncio.run(load([s.url for s in servers], codes, answers, args.duration, args.think))
    finally:
        for s in servers:
            s.stop()
    lat = sorted(log["latency"])

    def q(p: float) -> float:
        return 1000 * lat[min(len(lat) - 1, int(p * len(lat)))] if lat else float("nan")

    result = {
        "configuration": name, "students": len(codes), "duration_s": round(log["seconds"], 1), "think_s": args.think,
        "sign_in_all_s": round(log["sign_in_seconds"], 1),
        "acknowledged": len(log["acknowledged"]),
        "throughput_per_s": round(len(log["acknowledged"]) / log["seconds"], 1),
        "p50_ms": round(q(0.50), 1), "p95_ms": round(q(0.95), 1), "p99_ms": round(q(0.99), 1),
        "max_ms": round(1000 * lat[-1], 1) if lat else None, "mean_ms": round(1000 * statistics.fmean(lat), 1) if lat
        else None, "errors": len(log["errors"]), "resent": log["resent"], **check(db_url, log, 3),
    }
    for e in log["errors"][:5]:
        print(f"  error: {e}", file=sys.stderr)
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of load per configuration")
    ap.add_argument("--students", type=int, default=300)
    ap.add_argument("--think", type=float, default=5.0, help="mean pause between a student's submissions (s)")
    ap.add_argument("--only", choices=["sqlite", "postgresql", "postgresql-2"], action="append")
    args = ap.parse_args()
    prepare(args.students)
    codes, answers = class_data()
    wanted = args.only or ["sqlite", "postgresql", "postgresql-2"]
    results = []
    if "sqlite" in wanted:
        results.append(run("SQLite, 1 process", None, 1, codes, answers, args))
        print(json.dumps(results[-1]), flush=True)
    if {"postgresql", "postgresql-2"} & set(wanted):
        for name, processes in (("postgresql", 1), ("postgresql-2", 2)):
            if name not in wanted:
                continue
            with postgres_cluster() as url:  # a fresh database per configuration
                results.append(run(f"PostgreSQL, {processes} process{'es' if processes > 1 else ''}", url, processes,
                                   codes, answers, args))
            print(json.dumps(results[-1]), flush=True)
    print()
    print("| configuration | students | s | acknowledged | /s | p50 ms | p95 ms | p99 ms | errors | lost | duplicated "
          "| over limit | refused attempts |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        print(f"| {r['configuration']} | {r['students']} | {r['duration_s']} | {r['acknowledged']} | "
              f"{r['throughput_per_s']} | {r['p50_ms']} | {r['p95_ms']} | {r['p99_ms']} | {r['errors']} | "
              f"{r['lost']} | {r['duplicated']} | {r['over_limit']} | {r['refused_attempts']} |")


if __name__ == "__main__":
    main()
