"""The online page over HTTP: Starlette routes, server-rendered jinja2 pages that work without JavaScript.

Starlette because it is small, typed, kept by the encode team (with uvicorn) and asks for nothing
we do not use: routing, forms and uploads (python-multipart), responses; the pages are jinja2
templates as gradekit's documents are, rendered with autoescape and StrictUndefined. Database and
grading calls run in Starlette's thread pool, so one slow call never holds the event loop.

Every form carries a CSRF token tied to the session cookie; the cookie is HttpOnly, SameSite=Lax and
Secure when the request came over TLS (behind a proxy: uvicorn's ``--proxy-headers``). A student's
pages are found through their session only: no URL names a student.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import secrets
import zipfile
from pathlib import Path

import jinja2
from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import HTMLResponse, RedirectResponse, Response
from starlette.routing import Route

from gradekit.errors import GradekitError
from gradekit.units import pretty
from gradekit.web.access import Session, new_session, seal, unseal
from gradekit.web.service import EXPORT_FOLDER, Service, open_service, utc

log = logging.getLogger(__name__)

COOKIE = "gradekit_session"
MAX_UPLOAD = 2 * 1024 * 1024  # as the reader: a larger file is not an answers CSV
_HEADERS = {
    "Content-Security-Policy": "default-src 'none'; style-src 'unsafe-inline'; img-src 'self'; form-action 'self'; "
                               "frame-ancestors 'none'; base-uri 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "X-Frame-Options": "DENY",
    "Cache-Control": "no-store",
}
DOWNLOADS = {  # name -> (path below the export folder, media type)
    "grades.csv": ("graded/grades.csv", "text/csv; charset=utf-8"),
    "canvas.csv": ("graded/canvas.csv", "text/csv; charset=utf-8"),
    "moodle.csv": ("graded/moodle.csv", "text/csv; charset=utf-8"),
    "report.md": ("graded/report.md", "text/markdown; charset=utf-8"),
    "histogram.svg": ("graded/histogram.svg", "image/svg+xml"),
    "hand.csv": ("graded/hand.csv", "text/csv; charset=utf-8"),
    "attempts.csv": ("attempts.csv", "text/csv; charset=utf-8"),
    "online.csv": ("online.csv", "text/csv; charset=utf-8"),
    "feedback.zip": ("graded/feedback", "application/zip"),
    "submissions.zip": ("submissions", "application/zip"),
}


def _templates() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(Path(__file__).parent / "templates")),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        auto_reload=False,  # the templates are the installed package's: no stat() of each file per page
    )
    env.filters["pts"] = lambda x: f"{x:g}"
    env.filters["unit"] = pretty  # N·m, lbf·in, ° as the sheet prints them (the input keeps what is typed)
    return env


class Page:
    """The HTTP side of a `Service`."""

    def __init__(self, service: Service) -> None:
        self.service = service
        self.env = _templates()
        self.exports = Path(service.paths.manifest).parent / EXPORT_FOLDER

    # --- plumbing --------------------------------------------------------------------------------

    def session(self, request: Request) -> tuple[Session, bool]:
        """The request's session, or a fresh anonymous one (then True: its cookie is to be set)."""
        found = unseal(self.service.secret, request.cookies.get(COOKIE))
        return (found, False) if found is not None else (new_session(), True)

    def render(self, request: Request, name: str, session: Session, set_cookie: bool, status: int = 200,
               **context) -> HTMLResponse:
        asg = self.service.course.assignment
        body = self.env.get_template(name).render(
            csrf=session.csrf(self.service.secret), session=session, course=asg.course, title=asg.title, **context)
        response = HTMLResponse(body, status_code=status, headers=_HEADERS)
        if set_cookie:
            self.set_cookie(request, response, session)
        return response

    def set_cookie(self, request: Request, response: Response, session: Session) -> None:
        response.set_cookie(COOKIE, seal(self.service.secret, session), httponly=True, samesite="lax",
                            secure=request.url.scheme == "https", path="/")

    def redirect(self, to: str) -> RedirectResponse:
        return RedirectResponse(to, status_code=303, headers=_HEADERS)

    async def form(self, request: Request, session: Session):
        """The posted form, or None when its CSRF token is not this session's."""
        form = await request.form(max_files=1, max_fields=500, max_part_size=MAX_UPLOAD + 1024)
        token = form.get("csrf")
        if not isinstance(token, str) or not session.csrf_ok(self.service.secret, token):
            return None
        return form

    def refused(self, request: Request, session: Session, fresh: bool) -> HTMLResponse:
        return self.render(request, "message.html", session, fresh, 403, heading="Form expired",
                           message="This form is no longer valid (signed out, or opened in another session). "
                                   "Go back, reload the page and send it again.")

    @staticmethod
    def client(request: Request) -> str:
        return request.client.host if request.client else "?"

    # --- routes ----------------------------------------------------------------------------------

    async def home(self, request: Request) -> Response:
        session, _ = self.session(request)
        if session.role == "student":
            return self.redirect("/student")
        if session.role == "instructor":
            return self.redirect("/instructor")
        return self.redirect("/signin")

    async def signin(self, request: Request) -> Response:
        session, fresh = self.session(request)
        if request.method == "GET":
            return self.render(request, "signin.html", session, fresh, error="", student_id="")
        form = await self.form(request, session)
        if form is None:
            return self.refused(request, session, fresh)
        sid, code = str(form.get("student_id", "")), str(form.get("code", ""))
        result = await run_in_threadpool(self.service.sign_in_student, sid, code, self.client(request))
        if result != "ok":
            error = ("Too many failed sign-ins: wait a few minutes." if result == "limited"
                     else "That id and access code do not match. The code is printed on your sheet.")
            return self.render(request, "signin.html", session, fresh, 429 if result == "limited" else 401,
                               error=error, student_id=sid)
        response = self.redirect("/student")
        self.set_cookie(request, response, new_session("student", sid.strip()))
        return response

    async def signout(self, request: Request) -> Response:
        session, fresh = self.session(request)
        if await self.form(request, session) is None:
            return self.refused(request, session, fresh)
        response = self.redirect("/signin")
        self.set_cookie(request, response, new_session())
        return response

    def _student(self, request: Request) -> tuple[Session, bool, bool]:
        session, fresh = self.session(request)
        ok = session.role == "student" and session.student_id in self.service.course.by_id
        return session, fresh, ok

    async def student(self, request: Request) -> Response:
        session, fresh, ok = self._student(request)
        if not ok:
            return self.redirect("/signin")
        page = await run_in_threadpool(self.service.page, session.student_id)
        return self.student_page(request, session, fresh, page)

    def student_page(self, request: Request, session: Session, fresh: bool, page, receipt=None, status: int = 200):
        s = self.service.course.by_id[session.student_id]
        online = self.service.online
        return self.render(request, "student.html", session, fresh, status, page=page, receipt=receipt, student=s,
                           online=online, due=utc(self.service.due) if self.service.due else "",
                           form_id=secrets.token_urlsafe(16), at=utc(receipt.at) if receipt else "")

    async def _student_post(self, request: Request):  # noqa: ANN202
        """(the signed-in student's session, whether its cookie is new, the posted form), or the response
        to send instead (to the sign-in page, or refused for its CSRF token)."""
        session, fresh, ok = self._student(request)
        if not ok:
            return None, self.redirect("/signin")
        form = await self.form(request, session)
        if form is None:
            return None, self.refused(request, session, fresh)
        return (session, fresh, form), None

    async def submit(self, request: Request) -> Response:
        posted, refusal = await self._student_post(request)
        if refusal is not None:
            return refusal
        session, fresh, form = posted
        typed = {}
        for e in self.service.course.entries(session.student_id):
            value = form.get(f"value:{e.key}")
            if isinstance(value, str):
                unit = form.get(f"unit:{e.key}")
                typed[e.key] = (value, unit if isinstance(unit, str) else "")
        source = "upload" if form.get("source") == "upload" else "form"
        try:
            receipt, page = await run_in_threadpool(self.service.submit, session.student_id,
                                                    str(form.get("form_id", "")), typed, source)
        except GradekitError as exc:  # a form id another student's submission carries: nothing stored
            return self.render(request, "message.html", session, fresh, 409, heading="Not stored",
                               message=exc.format_message())
        return self.student_page(request, session, fresh, page, receipt)

    async def upload(self, request: Request) -> Response:
        posted, refusal = await self._student_post(request)
        if refusal is not None:
            return refusal
        session, fresh, form = posted
        upload = form.get("file")
        if upload is None or isinstance(upload, str):
            answers, read_as, messages, name = {}, {}, ["expected a file, got none"], ""
        else:
            name = os.path.basename(upload.filename or "answers.csv")[:100]
            data = await upload.read(MAX_UPLOAD + 1)
            answers, read_as, messages = await run_in_threadpool(self.service.read_upload, session.student_id, data,
                                                                 name)
        entries = self.service.course.entries(session.student_id)
        rows = [(e.key, e.description, *answers[e.key], read_as.get(e.key, "blank: your current answer stays"))
                for e in entries if e.key in answers]
        return self.render(request, "upload.html", session, fresh, rows=rows, messages=messages, filename=name,
                           form_id=secrets.token_urlsafe(16), closed=self.service.closed())

    async def instructor_signin(self, request: Request) -> Response:
        session, fresh = self.session(request)
        if request.method == "GET":
            return self.render(request, "instructor_signin.html", session, fresh, error="")
        form = await self.form(request, session)
        if form is None:
            return self.refused(request, session, fresh)
        result = await run_in_threadpool(self.service.sign_in_instructor, str(form.get("password", "")),
                                         self.client(request))
        if result != "ok":
            error = "Too many failed sign-ins: wait a few minutes." if result == "limited" else "Wrong password."
            return self.render(request, "instructor_signin.html", session, fresh, 429 if result == "limited" else 401,
                               error=error)
        response = self.redirect("/instructor")
        self.set_cookie(request, response, new_session("instructor"))
        return response

    async def instructor(self, request: Request) -> Response:
        session, fresh = self.session(request)
        if session.role != "instructor":
            return self.redirect("/instructor/signin")
        board = await run_in_threadpool(self.service.dashboard)
        return self.render(request, "instructor.html", session, fresh, board=board, downloads=self.available())

    def available(self) -> list[str]:
        return [n for n, (rel, _) in DOWNLOADS.items() if (self.exports / rel).exists()]

    async def grade_now(self, request: Request) -> Response:
        session, fresh = self.session(request)
        if session.role != "instructor":
            return self.redirect("/instructor/signin")
        if await self.form(request, session) is None:
            return self.refused(request, session, fresh)
        try:
            await run_in_threadpool(self.service.export, self.exports)
        except GradekitError as exc:
            return self.render(request, "message.html", session, fresh, 409, heading="Nothing graded",
                               message=exc.format_message())
        return self.redirect("/instructor#downloads")

    async def download(self, request: Request) -> Response:
        session, _ = self.session(request)
        if session.role != "instructor":
            return self.redirect("/instructor/signin")
        name = request.path_params["name"]
        if name not in DOWNLOADS or name not in self.available():
            return Response("not found", status_code=404, headers=_HEADERS)
        rel, media = DOWNLOADS[name]
        path = self.exports / rel
        data = await run_in_threadpool(_zipped if path.is_dir() else Path.read_bytes, path)
        return Response(data, media_type=media,
                        headers={**_HEADERS, "Content-Disposition": f'attachment; filename="{name}"'})

    def app(self) -> Starlette:
        routes = [
            Route("/", self.home),
            Route("/signin", self.signin, methods=["GET", "POST"]),
            Route("/signout", self.signout, methods=["POST"]),
            Route("/student", self.student),
            Route("/student/submit", self.submit, methods=["POST"]),
            Route("/student/upload", self.upload, methods=["POST"]),
            Route("/instructor/signin", self.instructor_signin, methods=["GET", "POST"]),
            Route("/instructor", self.instructor),
            Route("/instructor/grade", self.grade_now, methods=["POST"]),
            Route("/instructor/download/{name}", self.download),
        ]
        service = self.service

        @contextlib.asynccontextmanager
        async def lifespan(_app):  # noqa: ANN001, ANN202
            yield
            service.close()

        return Starlette(routes=routes, lifespan=lifespan, max_body_size=MAX_UPLOAD + 64 * 1024)


def _zipped(folder: Path) -> bytes:
    """A folder's files as a zip (names below the folder; sorted, so the same files give the same bytes)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as z:
        for path in sorted(folder.rglob("*")):
            if path.is_file() and not path.name.startswith("."):
                info = zipfile.ZipInfo(str(path.relative_to(folder)), date_time=(1980, 1, 1, 0, 0, 0))
                z.writestr(info, path.read_bytes(), zipfile.ZIP_DEFLATED)
    return buffer.getvalue()


def make_app(service: Service) -> Starlette:
    """The ASGI application of a service."""
    return Page(service).app()


def from_environment() -> Starlette:
    """The application for an ASGI server run by hand (``uvicorn --factory gradekit.web.app:from_environment``):
    the database in ``GRADEKIT_DB`` (a URL), the course as `gradekit serve --prepare` recorded it there."""
    url = os.environ.get("GRADEKIT_DB")
    if not url:
        raise GradekitError("expected the database URL in GRADEKIT_DB, got none")
    return make_app(open_service(url, None))


def serve(service: Service, host: str, port: int) -> None:
    """Run the page with uvicorn until interrupted."""
    import uvicorn

    uvicorn.run(make_app(service), host=host, port=port, log_level="warning", access_log=False,
                proxy_headers=True, forwarded_allow_ips="127.0.0.1", timeout_keep_alive=30)
