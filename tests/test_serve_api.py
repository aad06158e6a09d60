"""``usdworld serve``'s HTTP API through Starlette's test client: every operation, refusals
with the rule's reason, the session token, size limits, path traversal and crash safety."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
from starlette.testclient import TestClient
from test_serve_support import Targets, demo_world, find_targets, sha256

from usdworld.authoring.edits import WorldEditor
from usdworld.errors import UsdWorldError
from usdworld.resources import data_dir
from usdworld.serve import app as app_module
from usdworld.serve.app import STATIC_DIR, create_app
from usdworld.serve.payloads import MAX_BODY_BYTES
from usdworld.serve.session import WorldSession

TOKEN = "test-token-123"
HEADERS = {"X-Usdworld-Token": TOKEN}
BASE = "http://127.0.0.1:8765"
SURFACE_RULES = data_dir() / "surface_rules.json"
REPLACEMENT_RULES = data_dir() / "replacement_rules.json"


@pytest.fixture()
def world(tmp_path_factory, tmp_path) -> Path:
    return demo_world(tmp_path_factory, tmp_path / "demo")


@pytest.fixture()
def targets(world) -> Targets:
    return find_targets(world)


@pytest.fixture()
def twin(tmp_path_factory, tmp_path) -> WorldEditor:
    """The same world edited by the engine directly: what the server does must match it."""
    editor = WorldEditor(demo_world(tmp_path_factory, tmp_path / "twin"), clock=lambda: "")
    yield editor
    editor.close()


def engine(twin: WorldEditor, op: str, *args, **kwargs) -> str:
    """The engine's answer to one operation: its message, or the error's."""
    try:
        result = getattr(twin, op)(*args, **kwargs)
    except UsdWorldError as exc:
        return f"{type(exc).__name__}: {exc}"
    if isinstance(result, list):  # undo
        return "; ".join(f"undid step {e.step}: {e.op} {e.args.get('name', '')}".rstrip() for e in result)
    return f"{result.message} [step {result.step}]"


@pytest.fixture()
def session(world):
    s = WorldSession(world, clock=lambda: "")
    yield s
    s.close()


@pytest.fixture()
def client(session):
    with TestClient(create_app(session, TOKEN), base_url=BASE) as c:
        yield c


def post(client, op, body=None, **kw):
    return client.post(f"/api/{op}", json=body if body is not None else {}, headers=HEADERS, **kw)


def edits_layer(world: Path) -> Path:
    return world.parent / "layers" / "edits.usda"


def objects_on_disk(world: Path) -> dict:
    with WorldEditor(world) as e:
        return {o.name: o for o in e.objects()}


def glb_json(data: bytes) -> dict:
    magic, version, length = struct.unpack("<4sII", data[:12])
    assert (magic, version, length) == (b"glTF", 2, len(data))
    n, kind = struct.unpack("<I4s", data[12:20])
    assert kind == b"JSON"
    return json.loads(data[20 : 20 + n])


# --- page and static files ------------------------------------------------------------------


def test_page_and_bundled_three_are_served_without_a_token(client):
    page = client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert '<script type="module" src="/static/app.js">' in page.text
    assert "http://" not in page.text and "https://" not in page.text  # no CDN: works offline
    csp = page.headers["content-security-policy"]
    assert "default-src 'self'" in csp and "script-src 'self'" in csp
    assert page.headers["referrer-policy"] == "no-referrer"  # the URL holds the token
    app_js = client.get("/static/app.js")
    assert app_js.status_code == 200 and 'from "./vendor/three.bundle.js"' in app_js.text
    three = client.get("/static/vendor/three.bundle.js")
    assert three.status_code == 200 and "three 0.187.0" in three.text[:200]
    assert len(three.content) > 300_000  # the real build, not a stub
    assert (STATIC_DIR / "vendor" / "three.LICENSE.txt").is_file()


def test_static_files_cannot_leave_the_static_folder(client):
    for path in ("/static/../app.py", "/static/%2e%2e/app.py", "/static/..%2fapp.py", "/static//etc/passwd"):
        r = client.get(path)
        assert r.status_code == 404, path


# --- token and host ---------------------------------------------------------------------------


def test_token_is_required(client, world, targets):
    before = sha256(edits_layer(world))
    assert client.get("/api/world").status_code == 401
    assert client.get("/api/world", headers={"X-Usdworld-Token": "wrong"}).status_code == 401
    assert client.get("/api/scene.glb").status_code == 401
    r = client.post("/api/delete", json={"name": targets.car})
    assert r.status_code == 401 and "session token" in r.json()["error"]
    # a GET may carry the token in the query (for <img src>), a POST may not
    assert client.get(f"/api/version?token={TOKEN}").status_code == 200
    assert client.post(f"/api/delete?token={TOKEN}", json={"name": targets.car}).status_code == 401
    assert client.get("/api/version", headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200
    assert sha256(edits_layer(world)) == before


def test_foreign_host_header_is_refused(client):
    r = client.get("/api/version", headers={**HEADERS, "Host": "evil.example:8765"})
    assert r.status_code == 400


def test_mutation_needs_json_and_post(client, world):
    before = sha256(edits_layer(world))
    r = client.post(
        "/api/delete",
        content=b"name=car_0002",
        headers={**HEADERS, "Content-Type": "application/x-www-form-urlencoded"},
    )
    assert r.status_code == 415
    assert client.put("/api/delete", json={"name": "car_0002"}, headers=HEADERS).status_code == 405
    assert sha256(edits_layer(world)) == before


# --- reading --------------------------------------------------------------------------------


def test_world_snapshot(client, world, targets):
    r = client.get("/api/world", headers=HEADERS)
    assert r.status_code == 200 and r.headers["cache-control"] == "no-store"
    w = r.json()
    assert len(w["objects"]) == targets.count and all(o["active"] for o in w["objects"])
    with WorldEditor(world) as e:
        states = {o.name: o for o in e.objects()}
        from usdworld.authoring.provenance import read_values

        values = read_values(e.stage.GetPrimAtPath(states[targets.car].path))
    assert [o["name"] for o in w["objects"]] == list(states)
    car = next(o for o in w["objects"] if o["name"] == targets.car)
    state = states[targets.car]
    assert car["class"] == "car" and car["status"] == "base" and car["surface"] == "road"
    assert car["variant"] == state.variant and car["position_m"] == pytest.approx(list(state.position_world))
    assert car["depth_method"] == values["usdworld:depthMethod"]
    assert car["depth_m"] == pytest.approx(values["usdworld:depth"])
    prov = car["provenance"]
    names = list(values["usdworld:depthCueNames"])
    assert [c["name"] for c in prov["depth_cues"]] == names and names
    for cue, value in zip(prov["depth_cues"], values["usdworld:depthCueValues"]):
        assert (
            cue["depth_m"] is None if np.isnan(value) else cue["depth_m"] == pytest.approx(value)
        )  # NaN -> null
    assert prov["yaw_source"] == values["usdworld:yawSource"]
    assert prov["scale_factor"] == pytest.approx(values["usdworld:scaleFactor"])
    assert prov["image_bbox_px"] == pytest.approx(list(values["usdworld:imageBBox"]))
    assert w["scene"]["image_size_px"] == [1024, 512]
    assert w["scene"]["dlt_rms_px"] < 1e-6 and w["scene"]["dlt_source"] == "camera_model"
    assert w["photo"] is True  # the demo's photo, from the package's demo data
    assert w["views"] == []  # one view: no view picker
    classes = w["classes"]
    assert classes["replace_with"]["car"] == {
        "bus": classes["variants"]["bus"],
        "car": ["hatchback", "sedan", "suv"],
        "truck": ["box_truck"],
    }
    assert "car" in classes["addable"] and classes["default_variant"]["car"] in classes["variants"]["car"]
    assert w["history"] == [] and w["can_undo"] is False and w["can_redo"] is False


def test_camera_reproduces_the_photo_pixels(client, session):
    """The projection the page uses maps the DLT's ground points onto their pixels (exact intrinsics)."""
    cam = client.get("/api/world", headers=HEADERS).json()["camera"]
    assert (cam["width"], cam["height"]) == (1024, 512)
    P = np.array(cam["projection"]).reshape(4, 4).T  # column-major, as three.js
    world_from_glcam = np.array(cam["world_from_glcam"]).reshape(4, 4).T
    values = session.scene_values
    pixels = np.array(values["usdworld:dltPixels"]).reshape(-1, 2)
    ground = np.array(values["usdworld:dltGround"]).reshape(-1, 2)
    pts = np.column_stack([ground, np.zeros(len(ground)), np.ones(len(ground))])
    clip = (P @ np.linalg.inv(world_from_glcam) @ pts.T).T
    ndc = clip[:, :2] / clip[:, 3:4]
    u = (ndc[:, 0] + 1) / 2 * cam["width"] - 0.5
    v = (1 - ndc[:, 1]) / 2 * cam["height"] - 0.5
    np.testing.assert_allclose(np.column_stack([u, v]), pixels, atol=1e-3)


def test_scene_glb_has_one_node_per_object(client, targets):
    r = client.get("/api/scene.glb", headers=HEADERS)
    assert r.status_code == 200 and r.headers["content-type"] == "model/gltf-binary"
    version = client.get("/api/version", headers=HEADERS).json()["version"]
    assert r.headers["x-usdworld-version"] == version
    doc = glb_json(r.content)
    names = {n["name"] for n in doc["nodes"]}
    assert names == {
        "ground",
        *(o["name"] for o in client.get("/api/world", headers=HEADERS).json()["objects"]),
    }
    prim = doc["meshes"][0]["primitives"][0]["attributes"]
    assert {"POSITION", "NORMAL", "COLOR_0"} <= set(prim)
    # Y up: the ground lies at y ~ 0 in glTF coordinates
    ground = next(n for n in doc["nodes"] if n["name"] == "ground")
    acc = doc["accessors"][doc["meshes"][ground["mesh"]]["primitives"][0]["attributes"]["POSITION"]]
    assert abs(acc["min"][1]) < 0.5 and abs(acc["max"][1]) < 0.5
    # deleted objects leave the scene
    assert post(client, "delete", {"name": targets.car}).status_code == 200
    doc = glb_json(client.get("/api/scene.glb", headers=HEADERS).content)
    assert targets.car not in {n["name"] for n in doc["nodes"]} and len(doc["nodes"]) == len(names) - 1


def test_photo(client, world, session):
    r = client.get(f"/api/photo?token={TOKEN}")
    assert r.status_code == 200 and r.headers["content-type"] == "image/png" and r.content[:4] == b"\x89PNG"
    session.photo = None
    r = client.get("/api/photo", headers=HEADERS)
    assert r.status_code == 404 and "--photo" in r.json()["error"]


def test_photo_in_the_world_folder_is_found(world):
    (world.parent / "demo_000000_000019_leftImg8bit.png").write_bytes(b"\x89PNG fake")
    with_photo = WorldSession(world)
    assert with_photo.photo == (world.parent / "demo_000000_000019_leftImg8bit.png").resolve()
    with_photo.close()
    from usdworld.demo import demo_dir

    given = demo_dir() / "demo_000000_000019_gtFine_labelIds.png"
    explicit = WorldSession(world, photo=given)  # --photo wins
    assert explicit.photo == given.resolve()
    explicit.close()


# --- files and traversal ------------------------------------------------------------------------


def test_world_files_and_traversal(client, world, tmp_path):
    r = client.get("/api/files/layers/edits.usda", headers=HEADERS)
    assert r.status_code == 200 and r.text.startswith("#usda 1.0")
    assert client.get("/api/files/world.usda", headers=HEADERS).status_code == 200
    secret = tmp_path / "secret.txt"
    secret.write_text("outside the world")
    (world.parent / "link_out").symlink_to(secret)
    (world.parent / "layers" / "edits.usda.lock").write_text("")
    for path in (
        "/api/files/../secret.txt",
        "/api/files/%2e%2e/secret.txt",
        "/api/files/layers/%2e%2e/%2e%2e/secret.txt",
        "/api/files/..%2fsecret.txt",
        "/api/files/%2Fetc%2Fpasswd",
        "/api/files//etc/passwd",
        "/api/files/link_out",
        "/api/files/layers/edits.usda.lock",
        "/api/files/layers\\..\\..\\secret.txt",
        "/api/files/layers",
        "/api/files/nope.usda",
    ):
        r = client.get(path, headers=HEADERS)
        assert r.status_code in (400, 404), path
        assert "outside the world" not in r.text


def test_resolve_file_refuses_every_way_out(session):
    for rel in (
        "../x",
        "a/../../x",
        "/etc/passwd",
        "",
        ".",
        "layers/./edits.usda",
        ".hidden",
        "a\\b",
        "a\x00b",
    ):
        with pytest.raises(FileNotFoundError):
            session.resolve_file(rel)
    assert session.resolve_file("layers/base.usda").name == "base.usda"


# --- every operation ------------------------------------------------------------------------------


def test_every_operation_goes_through_the_engine(client, world, targets, twin):
    """Each request does exactly what the engine does on a twin of the world: same message, same layer."""
    t = targets
    steps = [
        ("move", {"name": t.car, "to": list(t.car_to)}, ("move", t.car), {"to": t.car_to}),
        ("move", {"name": t.car, "by": [0.0, 0.0]}, ("move", t.car), {"by": (0.0, 0.0)}),
        ("rotate", {"name": t.car, "yaw_deg": 180}, ("rotate", t.car, 180.0), {}),
        ("restyle", {"name": t.car, "color": "#00ff00"}, ("restyle", t.car, "#00ff00"), {}),
        ("add", {"class": "car", "at": list(t.add_at)}, ("add", "car", t.add_at), {}),
        ("add", {"class": "car", "at": list(t.add_at)}, ("add", "car", t.add_at), {}),  # refused: fit
        ("delete", {"name": t.person}, ("delete", t.person), {}),
        (
            "replace",
            {"name": t.car, "with": "car", "variant": "sedan"},
            ("replace", t.car, "car"),
            {"variant": "sedan"},
        ),
        ("reset", {"name": t.other_car}, ("reset", t.other_car), {}),  # refused: no edits
        ("rotate", {"name": t.other_car, "yaw_deg": 0}, ("rotate", t.other_car, 0.0), {}),
        ("reset", {"name": t.other_car}, ("reset", t.other_car), {}),
        ("undo", {"steps": 1}, ("undo", 1), {}),
    ]
    for op, body, call, kwargs in steps:
        r = post(client, op, body)
        expected = engine(twin, *call, **kwargs)
        data = r.json()
        if r.status_code == 200:
            assert data["ok"] is True and data["message"] == expected, (op, body)
            assert data["version"] == client.get("/api/version", headers=HEADERS).json()["version"]
        else:
            assert data["code"] == ("not_permissible" if r.status_code == 409 else "nothing_to_reset")
            assert (
                expected.replace(str(twin.root.parent), str(world.parent)) == f"EditRefused: {data['error']}"
            ), (
                op,
                body,
            )
        assert edits_layer(world).read_bytes() == twin.edits_path.read_bytes(), (op, body)
    ops = [h["op"] for h in client.get("/api/world", headers=HEADERS).json()["history"]]
    assert (
        ops
        == ["move", "move", "rotate", "restyle", "add", "delete", "replace", "rotate", "reset"][: len(ops)]
    )
    assert len(ops) >= 8  # at most the second add (fit) and the first reset were refused
    on_disk = objects_on_disk(world)
    car = on_disk[t.car]
    assert (
        car.position_world[:2] == pytest.approx(t.car_to)
        and car.color == "#00ff00"
        and car.status == "edited"
    )
    assert on_disk[t.person].active is False
    added = [o for o in on_disk.values() if o.status == "added"]
    assert len(added) == 1 and added[0].position_world[:2] == pytest.approx(t.add_at)
    w = client.get("/api/world", headers=HEADERS).json()
    added_obj = next(o for o in w["objects"] if o["name"] == added[0].name)
    assert added_obj["depth_method"] == "user" and added_obj["provenance"]["depth_cues"] == []


def test_undo_and_redo(client, world, targets):
    t = targets
    base = edits_layer(world).read_bytes()
    assert post(client, "move", {"name": t.car, "to": list(t.car_to)}).status_code == 200
    after_move = edits_layer(world).read_bytes()
    assert post(client, "delete", {"name": t.person}).status_code == 200
    after_delete = edits_layer(world).read_bytes()

    r = post(client, "undo", {"steps": 2})
    assert r.status_code == 200
    assert r.json()["message"] == f"undid step 2: delete {t.person}; undid step 1: move {t.car}"
    assert edits_layer(world).read_bytes() == base  # the engine restores the layer exactly
    w = client.get("/api/world", headers=HEADERS).json()
    assert w["can_undo"] is False and w["can_redo"] is True

    r = post(client, "redo")
    assert r.status_code == 200 and r.json()["message"] == f"redid move {t.car} [step 1]"
    assert edits_layer(world).read_bytes() == after_move
    r = post(client, "redo")
    assert r.json()["message"] == f"redid delete {t.person} [step 2]"
    assert edits_layer(world).read_bytes() == after_delete
    r = post(client, "redo")
    assert r.status_code == 400 and "nothing to redo" in r.json()["error"]

    # a new edit drops the redo stack
    post(client, "undo")
    assert client.get("/api/world", headers=HEADERS).json()["can_redo"] is True
    assert post(client, "rotate", {"name": t.car, "yaw_deg": 180}).status_code == 200
    assert post(client, "redo").status_code == 400

    # nothing to undo
    post(client, "undo", {"steps": 2})
    r = post(client, "undo")
    assert r.status_code == 400 and "only 0 edit(s) recorded" in r.json()["error"]


def test_redo_is_void_after_an_edit_elsewhere(client, world, targets):
    post(client, "move", {"name": targets.car, "to": list(targets.car_to)})
    post(client, "undo")
    with WorldEditor(world) as other:  # like `usdworld edit` in a shell
        other.delete(targets.person)
    r = post(client, "redo")
    assert r.status_code == 400 and "changed since the undo" in r.json()["error"]
    assert [e.op for e in WorldEditor(world).history()] == ["delete"]


# --- refusals ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", ["sidewalk", "onto_car", "class", "add_onto_car"])
def test_refused_edits_say_which_rule_and_write_nothing(client, world, targets, twin, case):
    t = targets
    op, body, call, kwargs, rule = {
        "sidewalk": (
            "move",
            {"name": t.car, "to": list(t.sidewalk)},
            ("move", t.car),
            {"to": t.sidewalk},
            "surface",
        ),
        "onto_car": (
            "move",
            {"name": t.car, "to": list(t.other_xy)},
            ("move", t.car),
            {"to": t.other_xy},
            "fit",
        ),
        "class": ("replace", {"name": t.car, "with": "person"}, ("replace", t.car, "person"), {}, "class"),
        "add_onto_car": (
            "add",
            {"class": "car", "at": list(t.other_xy)},
            ("add", "car", t.other_xy),
            {},
            "fit",
        ),
    }[case]
    before = sha256(edits_layer(world))
    r = post(client, op, body)
    assert r.status_code == 409
    data = r.json()
    assert data["ok"] is False and data["refused"] is True
    assert f"EditRefused: {data['error']}" == engine(twin, *call, **kwargs)
    assert data["code"] == "not_permissible" and "--force" not in data["error"]
    assert data["reasons"] == [f"{v['rule']}: {v['message']}" for v in data["violations"]]
    assert " refused: " in data["error"] and "nothing was written" in data["error"]
    assert any(reason.startswith(f"{rule}: ") for reason in data["reasons"]), data["reasons"]
    assert all(reason in data["error"] for reason in data["reasons"])
    if rule == "class":
        assert data["reasons"] == [
            f"class: car may be replaced by bus, car, truck, not person (rules: {REPLACEMENT_RULES})"
        ]
    if rule == "surface":
        assert f"surface: car may stand on road, not sidewalk (rules: {SURFACE_RULES})" in data["reasons"]
    assert sha256(edits_layer(world)) == before


def test_refusals_are_worded_for_the_page_as_json(client, world, targets):
    t = targets
    before = sha256(edits_layer(world))
    r = post(client, "move", {"name": t.car, "to": list(t.other_xy)})
    assert r.status_code == 409
    data = r.json()
    fit = next(v for v in data["violations"] if v["rule"] == "fit")
    assert fit["object"] and fit["amount_m"] > 0.0
    assert fit["message"] == f"overlaps {fit['object']} by {fit['amount_m']:.2f} m"
    assert data["error"].startswith(f"move {t.car} refused: fit: overlaps ")
    assert data["error"].endswith("; nothing was written")
    r = post(client, "delete", {"name": "car_9999"})
    assert (r.status_code, r.json()) == (
        400,
        {
            "ok": False,
            "code": "unknown_object",
            "error": "no object 'car_9999' in this world; the object list shows the names",
            "refused": False,
            "op": "delete",
            "subject": "car_9999",
            "field": "",
            "choices": [],
            "reasons": [],
            "violations": [],
        },
    )
    r = post(client, "replace", {"name": t.car, "with": "car"})
    assert r.status_code == 400 and r.json()["code"] == "same_class"
    assert r.json()["error"] == f"{t.car} is already a car; choose a variant (one of hatchback, sedan, suv)"
    r = post(client, "rotate", {"name": t.car, "yaw_deg": 10})
    assert r.status_code == 200
    post(client, "delete", {"name": t.person})
    r = post(client, "move", {"name": t.person, "by": [1.0, 0.0]})
    assert (r.status_code, r.json()["code"]) == (400, "deleted_object")
    assert r.json()["error"] == f"{t.person} is deleted; Reset it or Undo to bring it back"
    assert before != sha256(edits_layer(world))  # the rotate and the delete went through


@pytest.mark.parametrize(
    "headers",
    [
        {"Origin": "http://evil.example"},
        {"Origin": "null"},
        {"Origin": "http://127.0.0.1:9999"},  # another port is another origin
        {"Referer": "http://evil.example/page"},
    ],
)
def test_cross_origin_mutations_are_refused(client, world, targets, headers):
    before = sha256(edits_layer(world))
    r = client.post("/api/delete", json={"name": targets.car}, headers={**HEADERS, **headers})
    assert r.status_code == 403
    assert r.json()["ok"] is False and r.json()["error"].startswith("cross-origin request refused: ")
    for method in ("put", "patch", "delete"):
        assert getattr(client, method)("/api/delete", headers={**HEADERS, **headers}).status_code == 403
    assert sha256(edits_layer(world)) == before
    assert client.get("/api/version", headers={**HEADERS, **headers}).status_code == 200  # reading is fine


@pytest.mark.parametrize("headers", [{"Origin": BASE}, {"Referer": f"{BASE}/?token={TOKEN}"}, {}])
def test_same_origin_mutations_pass(client, targets, headers):
    r = client.post("/api/delete", json={"name": targets.car}, headers={**HEADERS, **headers})
    assert r.status_code == 200, r.json()


def test_ipv6_loopback_host_is_accepted(session):
    with TestClient(create_app(session, TOKEN), base_url="http://[::1]:8765") as c:
        assert c.get("/api/version", headers=HEADERS).status_code == 200
        r = c.post("/api/delete", json={"name": "x"}, headers={**HEADERS, "Origin": "http://[::1]:8765"})
        assert r.status_code == 400 and r.json()["code"] == "unknown_object"


# --- validation and size limits ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "op, body, status, says",
    [
        ("move", {"name": "CAR"}, 400, "exactly one of"),
        ("move", {"name": "CAR", "to": [1, 2], "by": [1, 2]}, 400, "exactly one of"),
        ("move", {"name": "CAR", "to": [1]}, 400, "must be [x, y]"),
        ("move", {"name": "CAR", "to": ["a", 2]}, 400, "must be a number"),
        ("move", {"name": "CAR", "to": [True, 2]}, 400, "must be a number"),
        ("move", {"name": "CAR", "to": [1e300, 2]}, 400, "finite and within"),
        ("rotate", {"name": "CAR"}, 400, "missing field(s) yaw_deg"),
        ("rotate", {"name": "CAR", "yaw_deg": 1, "force": True}, 400, "unknown field(s) force"),
        ("delete", {"name": 3}, 400, "must be a string"),
        ("delete", {"name": "x" * 300}, 400, "1 to 200 characters"),
        ("delete", {"name": "nobody_0001"}, 400, "no object 'nobody_0001'"),
        ("delete", {"name": "../../etc"}, 400, "not an object name"),
        ("add", {"class": "../../etc/passwd", "at": [1, 2]}, 400, "is not a class or variant name"),
        ("add", {"class": "dragon", "at": [12, -2]}, 400, "'dragon'"),
        ("replace", {"name": "CAR", "with": "car", "variant": "tank"}, 400, "has no variant 'tank'"),
        ("restyle", {"name": "CAR", "color": "green"}, 400, "expected a hex colour"),
        ("undo", {"steps": 0}, 400, "integer from 1 to"),
        ("undo", {"steps": "1"}, 400, "integer from 1 to"),
        ("explode", {}, 404, "no operation 'explode'"),
    ],
)
def test_invalid_requests_are_rejected(client, world, targets, op, body, status, says):
    before = sha256(edits_layer(world))
    body = {k: (targets.car if v == "CAR" else v) for k, v in body.items()}
    r = post(client, op, body)
    assert r.status_code == status, r.text
    assert says in r.json()["error"]
    assert sha256(edits_layer(world)) == before


def test_malformed_json_is_rejected(client):
    for raw in (b"{", b"[1, 2]", b'{"name": NaN}', b"\xff\xfe"):
        r = client.post("/api/delete", content=raw, headers={**HEADERS, "Content-Type": "application/json"})
        assert r.status_code == 400, raw


def test_oversized_bodies_are_rejected(client, world):
    before = sha256(edits_layer(world))
    big = json.dumps({"name": "car_0002", "pad": "x" * (MAX_BODY_BYTES + 10)}).encode()
    r = client.post("/api/delete", content=big, headers={**HEADERS, "Content-Type": "application/json"})
    assert r.status_code == 413 and "more than the" in r.json()["error"]

    def chunks():  # no Content-Length: the limit holds while streaming
        yield b'{"name": "car_0002", "pad": "'
        for _ in range(40):
            yield b"x" * 1024
        yield b'"}'

    r = client.post("/api/delete", content=chunks(), headers={**HEADERS, "Content-Type": "application/json"})
    assert r.status_code == 413
    r = client.post(
        "/api/delete",
        content=b"{}",
        headers={**HEADERS, "Content-Type": "application/json", "Content-Length": "abc"},
    )
    assert r.status_code == 400
    assert sha256(edits_layer(world)) == before


# --- live sync and crash safety ------------------------------------------------------------------------


def test_version_follows_edits_made_elsewhere(client, world, targets):
    v0 = client.get("/api/version", headers=HEADERS).json()["version"]
    assert client.get("/api/version", headers=HEADERS).json()["version"] == v0
    with WorldEditor(world) as other:
        other.delete(targets.other_car)
    v1 = client.get("/api/version", headers=HEADERS).json()["version"]
    assert v1 != v0
    w = client.get("/api/world", headers=HEADERS).json()
    assert w["version"] == v1
    assert next(o for o in w["objects"] if o["name"] == targets.other_car)["status"] == "deleted"
    doc = glb_json(client.get("/api/scene.glb", headers=HEADERS).content)
    assert targets.other_car not in {n["name"] for n in doc["nodes"]}


def test_a_crash_while_saving_leaves_the_layer_intact(client, world, targets, monkeypatch):
    from usdworld.authoring.editing import transaction as edits

    path = edits_layer(world)
    before = path.read_bytes()
    real = edits.atomic_write_text

    def crash(target, text):  # half a temporary file, then the process "dies"
        (Path(target).parent / f".{Path(target).name}.crash.tmp").write_text(text[: len(text) // 2])
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(edits, "atomic_write_text", crash)
    r = post(client, "move", {"name": targets.car, "to": list(targets.car_to)})
    assert r.status_code == 500 and "disk on fire" in r.json()["error"]
    assert path.read_bytes() == before
    monkeypatch.setattr(edits, "atomic_write_text", real)
    # the editor rolled back: the next edit is step 1 and the stale temporary file is gone
    r = post(client, "delete", {"name": targets.person})
    assert r.status_code == 200 and r.json()["step"] == 1
    assert not list(path.parent.glob(".edits.usda.*.tmp"))
    assert [e.op for e in WorldEditor(world).history()] == ["delete"]


def test_unexpected_errors_answer_500_without_a_traceback(client, monkeypatch, session):
    monkeypatch.setattr(session, "snapshot", lambda: 1 / 0)
    r = client.get("/api/world", headers=HEADERS)
    assert r.status_code == 500 and r.json()["error"].startswith("internal error (ZeroDivisionError")


def test_shutdown_closes_the_session(world):
    closed = []
    s = WorldSession(world)
    app = create_app(s, TOKEN, on_shutdown=lambda: closed.append(s.close()))
    with TestClient(app, base_url=BASE) as c:
        assert c.get("/api/version", headers=HEADERS).status_code == 200
    assert closed == [None]


def test_hosts_can_be_opened_up_on_purpose(world):
    s = WorldSession(world)
    with TestClient(create_app(s, TOKEN, allowed_hosts=None), base_url="http://192.0.2.7:8765") as c:
        assert c.get("/api/version", headers=HEADERS).status_code == 200
    s.close()
    assert app_module.LOOPBACK_HOSTS == ("127.0.0.1", "localhost", "::1", "[::1]")
