"""Fuzzing of edit arguments (``usdworld edit``) and of the web editor's JSON bodies (``usdworld serve``).

Hostile values -- NaN, infinities, 1e308, huge integers and strings, wrong types, unknown
names, classes and fields -- go through the public entry points only: the CLI's ``main()``
and HTTP requests to the app. Every outcome must be a success or a clean refusal:

* CLI: exit 0, or exit 2 with a message and no traceback and no "unexpected" internal error
  (exit 1 is how ``main()`` reports a bug);
* HTTP: a 2xx answer, or a 4xx answer whose body is ``{"ok": false, "error": "..."}``; never 5xx.

And whatever happens, the world's base layer and root layer keep their bytes (edits go to
``layers/edits.usda`` only). One small world per module, built once (test_edit_support).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from starlette.testclient import TestClient
from test_edit_support import fresh_world, sha256

from usdworld.cli.main import main
from usdworld.serve.app import create_app
from usdworld.serve.session import WorldSession

FUZZ = settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
#: A request costs a few milliseconds, an edit command a tenth of a second: more requests.
API_FUZZ = settings(FUZZ, max_examples=300)
TOKEN = "fuzz-token"
BASE = "http://127.0.0.1:8765"
HEADERS = {"X-Usdworld-Token": TOKEN, "Origin": BASE, "Content-Type": "application/json"}
OBJECTS = ("car_0001", "car_0002", "person_0001")
HUGE = "9" * 5000
INF_LITERAL = "<1e400>"

# --- hostile values ---------------------------------------------------------------------------

_text = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=40)
floats = st.one_of(
    st.sampled_from(
        [math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, -0.0, 1e6, 1e6 + 1, 4e5, -3.0, 2.5]
    ),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-60, max_value=60),  # plausible positions, so some edits succeed
)
numbers = st.one_of(
    floats,
    st.sampled_from([10**400, -(10**400), 2**1024, 2**63, -(2**63), 10**6 + 1, 0]),  # beyond a double, int64
    st.integers(min_value=-(10**400), max_value=10**400),
)
names = st.one_of(
    st.sampled_from(OBJECTS),
    st.sampled_from(OBJECTS),  # twice: real names reach the rules and the edits layer
    st.sampled_from(
        ["/World/Objects/car_0001", "car_9999", "/World", "/World/Objects", "/", "..", "x" * 5000]
    ),
    st.sampled_from(
        ["/World/Objects/../Ground", "car_0001/../../x", "World.Objects", "car 0001", "\u00e9t\u00e9"]
    ),
    _text,
)
classes = st.one_of(
    st.sampled_from(["car", "person", "bus", "tree", "building", "pole", "Car", "__init__", "sky", "road"]),
    st.sampled_from(["../car", "car/../../etc", "car.usda", "", "x" * 5000, "car;rm"]),
    _text,
)
variants = st.one_of(st.sampled_from(["suv", "city", "default", "sedan", "", "../x", "y" * 5000]), _text)
colors = st.one_of(
    st.sampled_from(["#c03030", "#FFF", "#fff0", "#GGGGGG", "red", "", "#" + "f" * 5000, "nan", "#-1-1-1"]),
    _text,
)


def number_text(value: float) -> str:
    return repr(value) if isinstance(value, float) else str(value)


cli_numbers = st.one_of(
    numbers.map(number_text),
    st.sampled_from(
        ["1e400", "-1e400", "nan", "NaN", "-inf", "0x10", "1_000", "\u0661\u0662", "", " ", HUGE]
    ),
    _text,
)
on_the_road = st.tuples(st.floats(10, 40), st.floats(-4, 4))  # where a car may go: some edits succeed
cli_points = st.one_of(
    on_the_road.map(lambda p: f"{p[0]!r},{p[1]!r}"),
    st.tuples(numbers, numbers).map(lambda p: f"{number_text(p[0])},{number_text(p[1])}"),
    st.sampled_from(
        ["1,2,3", ",", "1,", ",1", "nan,nan", "inf,0", "1e308,1e308", "30 0", "30;0", HUGE + ",0"]
    ),
    _text,
)


# --- usdworld edit ----------------------------------------------------------------------------


def _flag(name: str, values: st.SearchStrategy[str]) -> st.SearchStrategy[list[str]]:
    """``[]`` or ``[name, value]``."""
    return st.one_of(st.just([]), values.map(lambda v: [name, v]))


_force = st.sampled_from([[], ["--force"]])
edit_commands = st.one_of(
    st.builds(
        lambda n, how, p, f: ["move", n, how, p, *f],
        names,
        st.sampled_from(["--to", "--by"]),
        cli_points,
        _force,
    ),
    st.builds(lambda n, y, f: ["rotate", n, "--yaw-deg", y, *f], names, cli_numbers, _force),
    st.builds(lambda n, f: ["delete", n, *f], names, _force),
    st.builds(
        lambda c, p, v, y, f: ["add", c, "--at", p, *v, *y, *f],
        classes,
        cli_points,
        _flag("--variant", variants),
        _flag("--yaw-deg", cli_numbers),
        _force,
    ),
    st.builds(
        lambda n, c, v, f: ["replace", n, "--with", c, *v, *f],
        names,
        classes,
        _flag("--variant", variants),
        _force,
    ),
    st.builds(lambda n, c: ["restyle", n, "--color", c], names, colors),
    st.builds(lambda n: ["undo", n], cli_numbers),
    st.builds(lambda n: ["reset", n], names),
)


@pytest.fixture(scope="module")
def cli_world(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[Path, str]]:
    """The module's world for the CLI and the digests of its base and root layers."""
    world = fresh_world(tmp_path_factory, tmp_path_factory.mktemp("cli") / "world")
    frozen = [world, world.parent / "layers" / "base.usda"]
    return world, {p: sha256(p) for p in frozen}


def _assert_clean_exit(args: list[str], code: int, err: str) -> None:
    assert code in (0, 2), f"edit {args!r}: exit {code}\n{err}"
    assert "Traceback" not in err and "unexpected" not in err, f"edit {args!r}: internal error\n{err}"
    if code == 2:
        assert err.strip(), f"edit {args!r}: exit 2 without a message"


@FUZZ
@given(args=edit_commands)
def test_edit_arguments_give_success_or_a_clean_error(
    args: list[str], cli_world: tuple[Path, dict[Path, str]], capsys: pytest.CaptureFixture[str]
) -> None:
    world, frozen = cli_world
    code = main(["edit", str(world), *args])
    _, err = capsys.readouterr()
    _assert_clean_exit(args, code, err)
    assert {p: sha256(p) for p in frozen} == frozen, f"edit {args!r} changed the base or root layer"


def test_the_fuzzed_world_still_lists_its_objects(
    cli_world: tuple[Path, dict[Path, str]], capsys: pytest.CaptureFixture[str]
) -> None:
    """Whatever the fuzz left in the edits layer, the world opens and lists."""
    world, frozen = cli_world
    assert main(["edit", str(world), "list"]) == 0
    assert capsys.readouterr().out.splitlines()[-1].endswith("deleted")
    assert {p: sha256(p) for p in frozen} == frozen


# --- usdworld serve ---------------------------------------------------------------------------

#: JSON numbers: NaN and infinities are not JSON (a body with them is refused whole), so they are rare
#: here; 1e400 is written as its literal, which Python's decoder reads as infinity.
json_numbers = st.one_of(
    st.sampled_from([1e308, -1e308, 5e-324, -0.0, 1e6 + 1, 10**400, -(10**400), 2**1024, 2**63, 0, 7]),
    st.floats(allow_nan=False, allow_infinity=False),
    st.floats(min_value=-60, max_value=60),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.sampled_from([math.nan, math.inf, INF_LITERAL]),
)
json_scalars = st.one_of(st.none(), st.booleans(), json_numbers, _text, st.just("z" * 5000))
json_values = st.recursive(
    json_scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(_text, inner, max_size=3)),
    max_leaves=8,
)
points = st.one_of(
    on_the_road.map(list),
    st.lists(json_numbers, min_size=2, max_size=2),
    st.lists(json_numbers, max_size=3),
    json_values,
)
#: For each operation: its required fields and its optional ones, with hostile values.
FIELDS: dict[str, tuple[dict[str, st.SearchStrategy], dict[str, st.SearchStrategy]]] = {
    "move": ({"name": names}, {"to": points, "by": points}),
    "rotate": ({"name": names, "yaw_deg": json_numbers}, {}),
    "delete": ({"name": names}, {}),
    "add": ({"class": classes, "at": points}, {"variant": variants, "yaw_deg": json_numbers}),
    "replace": ({"name": names, "with": classes}, {"variant": variants}),
    "restyle": ({"name": names, "color": colors}, {}),
    "reset": ({"name": names}, {}),
    "undo": ({}, {"steps": st.one_of(st.integers(-2, 5), json_numbers)}),
    "redo": ({}, {"steps": st.one_of(st.integers(-2, 5), json_numbers)}),
}


def _dumps(doc: object) -> bytes:
    """JSON text of ``doc``, with :data:`INF_LITERAL` written as the number 1e400."""
    return json.dumps(doc, allow_nan=True).replace(f'"{INF_LITERAL}"', "1e400").encode()


def _well_formed(op: str) -> st.SearchStrategy[tuple[str, bytes]]:
    """Every required field of ``op`` and some optional ones, each with a hostile value of its kind."""
    required, optional = FIELDS[op]
    return st.fixed_dictionaries(required, optional=optional).map(lambda body: (op, _dumps(body)))


def _retyped(op: str) -> st.SearchStrategy[tuple[str, bytes]]:
    """``op``'s fields with any JSON values (wrong types), maybe an unknown field or a missing one."""
    required, optional = FIELDS[op]
    keys = [*required, *optional]
    fields = st.dictionaries(st.sampled_from(keys), json_values, max_size=len(keys)) if keys else st.just({})
    extra = st.one_of(st.just({}), st.dictionaries(_text, json_values, min_size=1, max_size=2))
    return st.tuples(fields, extra).map(lambda fe: (op, _dumps({**fe[0], **fe[1]})))


api_requests = st.one_of(
    st.sampled_from(list(FIELDS)).flatmap(_well_formed),
    st.sampled_from(list(FIELDS)).flatmap(_well_formed),
    st.sampled_from(list(FIELDS)).flatmap(_retyped),
    st.tuples(
        st.sampled_from([*FIELDS, "teleport", "undo/../move"]), json_values.map(_dumps)
    ),  # not an object
    st.tuples(st.sampled_from(list(FIELDS)), st.binary(max_size=64)),  # not JSON
)


@pytest.fixture(scope="module")
def api(tmp_path_factory: pytest.TempPathFactory) -> tuple[TestClient, dict[Path, str]]:
    """A test client of the web editor on the module's world, and its base and root layer digests."""
    world = fresh_world(tmp_path_factory, tmp_path_factory.mktemp("api") / "world")
    frozen = [world, world.parent / "layers" / "base.usda"]
    digests = {p: sha256(p) for p in frozen}
    session = WorldSession(world, clock=lambda: "")
    with TestClient(create_app(session, TOKEN), base_url=BASE) as client:
        yield client, digests
    session.close()


def _assert_clean_answer(what: str, response) -> None:
    assert response.status_code < 500, f"{what}: {response.status_code} {response.text[:500]}"
    doc = response.json()
    assert isinstance(doc, dict), f"{what}: {response.text[:200]}"
    if response.status_code >= 400:
        assert doc.get("ok") is False and isinstance(doc.get("error"), str) and doc["error"], f"{what}: {doc}"


@API_FUZZ
@given(request=api_requests)
@example(
    request=("rotate", b'{"name": "car_0001", "yaw_deg": ' + b"9" * 400 + b"}")
)  # an int beyond a double
@example(request=("add", b'{"class": "car", "at": [1e400, 0]}'))  # JSON's own infinity
def test_api_bodies_give_success_or_a_clean_4xx(
    request: tuple[str, bytes], api: tuple[TestClient, dict[Path, str]]
) -> None:
    client, frozen = api
    op, raw = request
    response = client.post(f"/api/{op}", content=raw, headers=HEADERS)
    _assert_clean_answer(f"POST /api/{op} {raw[:200]!r}", response)
    assert {p: sha256(p) for p in frozen} == frozen, (
        f"POST /api/{op} {raw[:200]!r} changed the base or root layer"
    )


def test_the_fuzzed_world_still_answers(api: tuple[TestClient, dict[Path, str]]) -> None:
    """After the fuzz the world's state is still served whole, and the base is intact."""
    client, frozen = api
    response = client.get("/api/world", headers=HEADERS)
    assert response.status_code == 200 and isinstance(response.json()["objects"], list)
    assert {p: sha256(p) for p in frozen} == frozen
