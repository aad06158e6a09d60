"""``usdworld serve`` as a user runs it: the printed URL, a real uvicorn server on a loopback
port, Ctrl-C, a taken port, and the payload validation it relies on."""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from test_serve_support import ServerProcess, demo_world, find_targets

from usdworld.cli.main import main
from usdworld.errors import InputError
from usdworld.serve.app import STATIC_DIR
from usdworld.serve.payloads import EditRequest, decode_body, parse_edit
from usdworld.serve.server import bind


def request(
    url: str,
    token: str | None = None,
    body: dict | None = None,
    host: str | None = None,
    origin: str | None = None,
):
    headers = {"Content-Type": "application/json"}
    if token:
        headers["X-Usdworld-Token"] = token
    if host:
        headers["Host"] = host
    if origin:
        headers["Origin"] = origin
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(url, data=data, headers=headers, method="POST" if data else "GET")
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def test_serve_prints_the_url_edits_and_stops_cleanly_on_ctrl_c(tmp_path_factory, tmp_path):
    world = demo_world(tmp_path_factory, tmp_path / "demo")
    targets = find_targets(world)
    server = ServerProcess(world)
    try:
        assert server.lines[0] == f"usdworld serve: {world} ({targets.count} objects)"
        assert server.url.startswith("http://127.0.0.1:") and len(server.token) >= 32
        status, page = request(server.base + "/")
        assert status == 200 and b"/static/app.js" in page
        assert request(server.base + "/api/world")[0] == 401
        status, body = request(server.base + "/api/world", server.token)
        assert status == 200 and len(json.loads(body)["objects"]) == targets.count
        assert request(server.base + "/api/version", server.token, host="attacker.example")[0] == 400
        status, body = request(server.base + "/api/delete", server.token, {"name": targets.person})
        assert (
            status == 200 and json.loads(body)["message"] == f"deleted {targets.person} (inactive) [step 1]"
        )
    finally:
        code, out, err = server.stop()
    assert code == 0, err
    assert out.strip().splitlines()[-1] == "usdworld serve: stopped"
    assert "Traceback" not in err
    assert not list((world.parent / "layers").glob(".edits.usda.*.tmp"))
    assert "active = false" in (world.parent / "layers" / "edits.usda").read_text()


def test_serve_on_ipv6_loopback_prints_a_url_that_works(tmp_path_factory, tmp_path):
    world = demo_world(tmp_path_factory, tmp_path / "demo")
    targets = find_targets(world)
    server = ServerProcess(world, "--host", "::1")
    try:
        assert server.url.startswith("http://[::1]:") and server.url.endswith(f"/?token={server.token}")
        status, page = request(server.url)
        assert status == 200 and b"/static/app.js" in page
        status, body = request(server.base + "/api/world", server.token)
        assert status == 200 and len(json.loads(body)["objects"]) == targets.count
        status, body = request(
            server.base + "/api/delete", server.token, {"name": targets.person}, origin="http://evil.example"
        )
        assert status == 403 and json.loads(body)["ok"] is False
        status, body = request(
            server.base + "/api/delete", server.token, {"name": targets.person}, origin=server.base
        )
        assert status == 200, body
    finally:
        code, _, err = server.stop()
    assert code == 0, err


def test_serve_refuses_a_taken_port(tmp_path_factory, tmp_path, capsys):
    world = demo_world(tmp_path_factory, tmp_path / "demo")
    taken = bind("127.0.0.1", 0)
    try:
        code = main(["serve", str(world), "--port", str(taken.port)])
    finally:
        taken.sock.close()
    _, err = capsys.readouterr()
    assert code == 2
    assert err.startswith(f"error: --host 127.0.0.1 --port {taken.port}: cannot listen there (")
    assert "--port 0 for any free one" in err


def test_serve_refuses_a_missing_world_and_a_bad_photo(tmp_path_factory, tmp_path, capsys):
    assert main(["serve", str(tmp_path / "nowhere")]) == 2
    assert "no such world" in capsys.readouterr().err
    world = demo_world(tmp_path_factory, tmp_path / "demo")
    (tmp_path / "photo.txt").write_text("not a photo")
    assert main(["serve", str(world), "--photo", str(tmp_path / "photo.txt")]) == 2
    assert capsys.readouterr().err == f"error: --photo {tmp_path / 'photo.txt'}: not a PNG or JPEG file\n"


def test_bind_reports_the_chosen_port_and_loopback():
    listener = bind("127.0.0.1", 0)
    try:
        assert listener.port > 0 and listener.loopback
        assert listener.url("abc") == f"http://127.0.0.1:{listener.port}/?token=abc"
        with socket.create_connection(("127.0.0.1", listener.port), timeout=5):
            pass  # already listening: a browser opened at once waits in the backlog
    finally:
        listener.sock.close()
    wide = bind("0.0.0.0", 0)
    try:
        assert not wide.loopback and wide.url("t").startswith("http://127.0.0.1:")
    finally:
        wide.sock.close()


# --- payloads -----------------------------------------------------------------------------------


def test_parse_edit_known_answers():
    assert parse_edit("move", {"name": "car_0001", "to": [1, 2.5]}) == EditRequest(
        "move", {"name": "car_0001", "to": (1.0, 2.5)}
    )
    add = parse_edit("add", {"class": "car", "at": [3, -4], "variant": None, "yaw_deg": 90})
    assert dict(add.args) == {"class": "car", "at": (3.0, -4.0), "yaw_deg": 90.0}
    assert dict(parse_edit("undo", {}).args) == {}
    with pytest.raises(TypeError):
        add.args["class"] = "bus"  # type: ignore[index]


@pytest.mark.parametrize(
    "raw, says",
    [
        (b"x" * 20000, "more than the 16384 allowed"),
        (b"[]", "must be a JSON object"),
        (b'{"a": Infinity}', "not valid JSON"),
        (b"{", "not valid JSON"),
    ],
)
def test_decode_body_refuses(raw, says):
    with pytest.raises(InputError, match="request body") as info:
        decode_body(raw)
    assert says in str(info.value)


def test_decode_body_empty_is_an_empty_object():
    assert decode_body(b"") == {} and decode_body(b"  ") == {}


def test_committed_page_matches_the_webapp_sources(tmp_path):
    """usdworld/serve/static is what webapp/build.mjs makes of webapp/src (someone forgot to build?)."""
    webapp = Path(__file__).resolve().parents[1] / "webapp"
    if shutil.which("node") is None or not (webapp / "node_modules" / "esbuild").is_dir():
        pytest.skip("webapp/node_modules is not installed (tools/build_webapp.sh installs it)")
    out = tmp_path / "static"
    subprocess.run(["node", "build.mjs", "--out", str(out)], cwd=webapp, check=True, capture_output=True)
    built = sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    assert built == sorted(p.relative_to(STATIC_DIR) for p in STATIC_DIR.rglob("*") if p.is_file())
    for rel in built:
        assert (out / rel).read_bytes() == (STATIC_DIR / rel).read_bytes(), (
            f"{rel}: run tools/build_webapp.sh"
        )
