"""The Starlette application of ``usdworld serve``: the page, its files and a small JSON API.

Routes (``{op}`` is one of :data:`usdworld.serve.payloads.OPERATIONS`):

==============================  =====================================================
``GET /``                       the page (``static/index.html``)
``GET /static/...``             its script, styles and the bundled three.js
``GET /api/version``            ``{"version"}``: changes whenever a layer is saved
``GET /api/world``              version, camera, scene facts, objects with provenance,
                                classes (variants, allowed replacements), history, and
                                ``views`` (a multi-view world's cameras, [] for one view)
``GET /api/scene.glb``          the composed world as glTF binary (one node per object)
``GET /api/photo``              the source photo (404 when there is none); ``?view=NAME``
                                the photo of a multi-view world's view NAME
``GET /api/files/{path}``       a file inside the world folder (e.g. layers/edits.usda)
``POST /api/{op}``              an edit, undo or redo; JSON body, see payloads
==============================  =====================================================

Every ``/api`` request needs the session token: the ``X-Usdworld-Token`` header (GET
requests may also pass ``?token=``, for ``<img src>``); a POST must send it as the header,
with ``Content-Type: application/json`` and a body of at most
:data:`~usdworld.serve.payloads.MAX_BODY_BYTES`. Answers: 401 without the right token, 413
for a larger body, 415 for another content type, 400 for an invalid request, 409 with the
rules' reasons when the permissibility rules refuse an edit (nothing is written), 404 for
any file outside the world folder. A refused edit answers
``{"ok": false, "code", "error", "refused", "reasons", "violations", ...}``: ``code`` is
the library's :class:`~usdworld.errors.RefusalReason` and ``error`` a sentence worded
for the page's users (:func:`web_message`). Bound to a loopback address, the app also
refuses requests whose ``Host`` is not a loopback name (DNS rebinding).

As a second layer beside the token, a mutating request (POST, PUT, PATCH, DELETE) whose
``Origin`` -- or, without one, ``Referer`` -- is not the server's own origin is refused
with 403 (cross-site requests); a request with neither (a script, curl) is judged by its
token alone.
"""

from __future__ import annotations

import contextlib
import logging
import secrets
from collections.abc import AsyncIterator, Callable, Iterable
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.middleware import Middleware
from starlette.middleware.gzip import GZipMiddleware
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from usdworld.errors import EditRefused, InputError, RefusalReason, UsdWorldError
from usdworld.serve.payloads import MAX_BODY_BYTES, OPERATIONS, decode_body, parse_edit
from usdworld.serve.session import PHOTO_SUFFIXES, WorldSession

log = logging.getLogger(__name__)

STATIC_DIR = Path(__file__).resolve().parent / "static"
TOKEN_HEADER = "x-usdworld-token"
#: Hosts accepted when the server is bound to a loopback address (``[::1]`` as a URL has it).
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1", "[::1]")
#: Methods that change something; they must come from the server's own origin.
MUTATING_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
CONTENT_SECURITY_POLICY = (
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
    "connect-src 'self' data: blob:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'; "
    "form-action 'none'"
)
_SECURITY_HEADERS = [
    (b"content-security-policy", CONTENT_SECURITY_POLICY.encode()),
    (b"x-content-type-options", b"nosniff"),
    (b"referrer-policy", b"no-referrer"),  # the page's URL holds the token
    (b"x-frame-options", b"DENY"),
    (b"cross-origin-resource-policy", b"same-origin"),
]


def new_token() -> str:
    """A fresh per-session token (URL-safe, 192 bits)."""
    return secrets.token_urlsafe(24)


def _error(status: int, message: str, **extra: Any) -> JSONResponse:
    return JSONResponse({"ok": False, "error": message, **extra}, status_code=status)


def web_message(exc: EditRefused) -> str:
    """A refusal worded for the page's users: what the page offers, no command-line options."""
    name, reason = exc.subject, exc.reason
    if reason is RefusalReason.UNKNOWN_OBJECT and not exc.field:
        return f"no object '{name}' in this world; the object list shows the names"
    if reason is RefusalReason.DELETED_OBJECT:
        return f"{name} is deleted; Reset it or Undo to bring it back"
    if reason is RefusalReason.SAME_CLASS:
        return (
            f"{name} is already a {exc.value}; choose a variant (one of {', '.join(exc.choices) or 'none'})"
        )
    if reason is RefusalReason.UNKNOWN_VARIANT:
        return f"{name} has no variant '{exc.value}'; choose one of {', '.join(exc.choices) or 'none'}"
    return exc.message


def refusal_json(exc: EditRefused) -> tuple[int, dict[str, Any]]:
    """The status (409 for the rules, 400 otherwise) and JSON body of a refused edit."""
    refused = exc.reason is RefusalReason.NOT_PERMISSIBLE
    body = {
        "ok": False,
        "code": exc.reason.value,
        "error": web_message(exc),
        "refused": refused,
        "op": exc.op,
        "subject": exc.subject,
        "field": exc.field,
        "choices": list(exc.choices),
        "reasons": [str(v) for v in exc.violations],
        "violations": [
            {"rule": v.rule, "message": v.message, "object": v.other, "amount_m": round(v.amount_m, 3)}
            for v in exc.violations
        ],
    }
    return (409 if refused else 400), body


def _origin(url: str) -> str:
    """``scheme://host[:port]`` of a URL ('' when it has none), lower case."""
    scheme, sep, rest = url.partition("://")
    if not sep or not scheme or not rest:
        return ""
    return f"{scheme}://{rest.split('/', 1)[0].split('?', 1)[0].split('#', 1)[0]}".lower()


class ApiGuard:
    """ASGI middleware: token, content type and body size checks for ``/api``; security headers."""

    def __init__(self, app: ASGIApp, token: str) -> None:
        self.app, self.token = app, token

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = list(message.get("headers", []))
                headers += _SECURITY_HEADERS
                if scope["path"].startswith("/api/"):
                    headers.append((b"cache-control", b"no-store"))
                message["headers"] = headers
            await send(message)

        refusal = self._refusal(scope) if scope["path"].startswith("/api/") else None
        if refusal is not None:
            await refusal(scope, receive, send_with_headers)
            return
        await self.app(scope, receive, send_with_headers)

    def _refusal(self, scope: Scope) -> Response | None:
        request = Request(scope)
        method = scope["method"]
        given = request.headers.get(TOKEN_HEADER, "")
        if not given and request.headers.get("authorization", "").startswith("Bearer "):
            given = request.headers["authorization"][7:]
        if not given and method in ("GET", "HEAD"):
            given = request.query_params.get("token", "")
        if not given or not secrets.compare_digest(given.encode(), self.token.encode()):
            how = "the X-Usdworld-Token header" if method not in ("GET", "HEAD") else "the token"
            return _error(
                401, f"missing or wrong session token: send {how} from the URL `usdworld serve` printed"
            )
        if method in ("GET", "HEAD"):
            return None
        if method in MUTATING_METHODS:
            own = f"{scope.get('scheme', 'http')}://{request.headers.get('host', '')}".lower()
            origin = request.headers.get("origin")
            referer = request.headers.get("referer")
            if origin is not None:
                if origin.lower() != own:
                    return _error(
                        403, f"cross-origin request refused: Origin '{origin}' is not this server ({own})"
                    )
            elif referer is not None and _origin(referer) != own:
                return _error(403, f"cross-origin request refused: Referer is not from this server ({own})")
        if method != "POST":
            return _error(405, f"{method} is not allowed; edits are POST requests")
        ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if ctype != "application/json":
            return _error(415, f"content type must be application/json, got '{ctype or 'none'}'")
        length = request.headers.get("content-length")
        if length is not None:
            if not length.isdigit():
                return _error(400, f"bad Content-Length '{length}'")
            if int(length) > MAX_BODY_BYTES:
                return _error(413, f"request body: {length} bytes, more than the {MAX_BODY_BYTES} allowed")
        return None


async def read_limited(request: Request, limit: int = MAX_BODY_BYTES) -> bytes:
    """The request body, refusing (InputError) as soon as it grows past ``limit`` bytes."""
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > limit:
            raise _TooLarge(f"request body: more than the {limit} bytes allowed")
    return bytes(body)


class _TooLarge(InputError):
    pass


def create_app(
    session: WorldSession,
    token: str,
    *,
    allowed_hosts: Iterable[str] | None = LOOPBACK_HOSTS,
    on_shutdown: Callable[[], None] | None = None,
) -> Starlette:
    """The application for one session.

    Args:
        session: the world being edited.
        token: the session token every ``/api`` request must carry.
        allowed_hosts: ``Host`` names accepted (None: any, for a server exposed on purpose).
        on_shutdown: called once when the server stops (e.g. ``session.close``).
    """

    async def index(request: Request) -> Response:
        return FileResponse(STATIC_DIR / "index.html", media_type="text/html")

    async def version(request: Request) -> Response:
        return JSONResponse({"version": session.version()})

    async def world(request: Request) -> Response:
        return await _guarded(lambda: session.snapshot())

    async def scene(request: Request) -> Response:
        try:
            v, glb = await run_in_threadpool(session.scene_glb)
        except UsdWorldError as exc:
            return _error(500, str(exc))
        return Response(glb, media_type="model/gltf-binary", headers={"x-usdworld-version": v})

    async def photo(request: Request) -> Response:
        view = request.query_params.get("view")
        if view is not None:
            if view not in session.view_photos:
                return _error(404, f"no view '{view}' in this world")
            path = session.view_photo(view)
            if path is None:
                return _error(404, f"no photo of view '{view}': put it in or beside the world folder")
            return FileResponse(path, media_type=PHOTO_SUFFIXES[path.suffix.lower()])
        if session.photo is None:
            return _error(404, "no source photo: put it in the world folder or pass --photo")
        return FileResponse(session.photo, media_type=PHOTO_SUFFIXES[session.photo.suffix.lower()])

    async def files(request: Request) -> Response:
        try:
            path = session.resolve_file(request.path_params["path"])
        except FileNotFoundError:
            return _error(404, "no such file in the world folder")
        return FileResponse(path)

    async def edit(request: Request) -> Response:
        op = request.path_params["op"]
        if request.method != "POST":
            return _error(404, f"no such resource: {request.url.path}")
        if op not in OPERATIONS:
            return _error(404, f"no operation '{op}'; one of {', '.join(OPERATIONS)}")
        try:
            body = decode_body(await read_limited(request))
            edit_request = parse_edit(op, body)
        except _TooLarge as exc:
            return _error(413, str(exc))
        except InputError as exc:
            return _error(400, str(exc))
        return await _guarded(lambda: session.apply(edit_request))

    async def _guarded(call: Callable[[], dict[str, Any]]) -> Response:
        try:
            result = await run_in_threadpool(call)
        except EditRefused as exc:
            status, body = refusal_json(exc)
            return JSONResponse(body, status_code=status)
        except InputError as exc:
            return _error(400, str(exc))
        except UsdWorldError as exc:
            log.error("%s", exc)
            return _error(500, str(exc))
        except Exception as exc:  # a bug: the engine rolled back, the layer on disk is intact
            log.exception("request failed")
            return _error(500, f"internal error ({type(exc).__name__}: {exc}); nothing was written")
        result.setdefault("version", session.version())
        return JSONResponse(result)

    routes = [
        Route("/", index, methods=["GET", "HEAD"]),
        Route("/api/version", version, methods=["GET"]),
        Route("/api/world", world, methods=["GET"]),
        Route("/api/scene.glb", scene, methods=["GET"]),
        Route("/api/photo", photo, methods=["GET", "HEAD"]),
        Route("/api/files/{path:path}", files, methods=["GET", "HEAD"]),
        Route("/api/{op}", edit, methods=["GET", "POST"]),
        Mount("/static", app=StaticFiles(directory=STATIC_DIR), name="static"),
    ]
    middleware = [
        Middleware(ApiGuard, token=token),
        Middleware(GZipMiddleware, minimum_size=2048, compresslevel=5),
    ]
    if allowed_hosts is not None:
        middleware.insert(0, Middleware(TrustedHostMiddleware, allowed_hosts=list(allowed_hosts)))

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        yield
        if on_shutdown is not None:
            on_shutdown()

    return Starlette(routes=routes, middleware=middleware, lifespan=lifespan)
