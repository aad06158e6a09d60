"""The one USD mesh reader: fan for convex polygons (unchanged triangles), earcut for concave ones."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pxr import Sdf, Usd, UsdGeom, Vt

from usdworld.authoring import asset_library
from usdworld.authoring.mesh_reader import _fan, expand_primvar, read_topology, triangulate_polygons
from usdworld.authoring.usd_geometry import read_mesh
from usdworld.render.usd_mesh import mesh_triangles

#: An L (2 x 2 square less its top-right 1 x 1 quarter), counter-clockwise, starting at the corner
#: where a fan from the first corner leaves the polygon. Area 3.
L_SHAPE = np.array([[2, 1], [1, 1], [1, 2], [0, 2], [0, 0], [2, 0]], dtype=np.float64)
#: An arrow pointing +x (shaft 3 x 2, head to x = 5, barbs swept back to x = 3.5), starting at the
#: lower barb. Area 6 (shaft) + 4.5 (head) = 10.5.
ARROW = np.array([[3.5, 0], [5, 2], [3.5, 4], [3, 3], [0, 3], [0, 1], [3, 1]], dtype=np.float64)


def _shoelace(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _inside(point: np.ndarray, poly: np.ndarray) -> bool:
    """Even-odd ray test (points on an edge do not occur for the centroids tested)."""
    x, y = point
    inside = False
    for (x0, y0), (x1, y1) in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


def _signed_areas(poly: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = poly[tris[:, 0]], poly[tris[:, 1]], poly[tris[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _rotation(seed: int) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _in_3d(poly_2d: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The polygon placed in a random plane: (n, 3) points and the plane's unit normal."""
    rot = _rotation(seed)
    flat = np.concatenate([poly_2d, np.zeros((len(poly_2d), 1))], axis=1)
    return flat @ rot.T + np.array([4.0, -2.0, 7.0]), rot[:, 2]


def _cut(poly_2d: np.ndarray, seed: int = 0) -> np.ndarray:
    points, _ = _in_3d(poly_2d, seed)
    corners, face = triangulate_polygons(points, np.array([len(poly_2d)]), np.arange(len(poly_2d)))
    assert (face == 0).all()
    return corners


@pytest.mark.parametrize(("poly", "area"), [(L_SHAPE, 3.0), (ARROW, 10.5)], ids=["L", "arrow"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_concave_faces_cover_the_polygon_only(poly: np.ndarray, area: float, seed: int) -> None:
    tris = _cut(poly, seed)
    assert len(tris) == len(poly) - 2
    signed = _signed_areas(poly, tris)
    assert (signed > 0).all()  # wound like the (counter-clockwise) polygon
    assert signed.sum() == pytest.approx(area, rel=1e-12)
    for centroid in poly[tris].mean(axis=1):
        assert _inside(centroid, poly)


@pytest.mark.parametrize("poly", [L_SHAPE, ARROW], ids=["L", "arrow"])
def test_a_fan_from_the_first_corner_fails_these_faces(poly: np.ndarray) -> None:
    fan, _ = _fan(np.array([len(poly)]))
    centroids = poly[fan].mean(axis=1)
    assert not all(_inside(c, poly) for c in centroids)


def test_clockwise_concave_face_keeps_its_winding() -> None:
    tris = _cut(L_SHAPE[::-1].copy())
    assert (_signed_areas(L_SHAPE[::-1], tris) < 0).all()
    assert -_signed_areas(L_SHAPE[::-1], tris).sum() == pytest.approx(3.0)


def test_concave_arrow_quad() -> None:
    arrow = np.array([[0.0, 0.0], [2.0, 1.0], [0.0, 2.0], [1.0, 1.0]])  # reflex corner at (1, 1)
    tris = _cut(arrow)
    assert _signed_areas(arrow, tris).sum() == pytest.approx(1.0)
    assert (_signed_areas(arrow, tris) > 0).all()


def test_convex_faces_keep_the_fan_exactly() -> None:
    """Triangles, convex quads and convex n-gons give the fan, corner for corner (same order)."""
    rng = np.random.default_rng(3)
    counts = np.array([3, 4, 6, 4, 3, 5])
    polys = []
    for n in counts:
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        polys.append(np.stack([np.cos(angles), np.sin(angles)], axis=1) * 2.0)  # convex: on a circle
    points, _ = _in_3d(np.concatenate(polys), 5)
    indices = rng.permutation(len(points))  # corners need not be stored in order
    points = points[np.argsort(indices)]
    corners, face = triangulate_polygons(points, counts, indices)
    fan_corners, fan_face = _fan(counts)
    np.testing.assert_array_equal(corners, fan_corners)
    np.testing.assert_array_equal(face, fan_face)


def test_mixed_mesh_orders_triangles_by_face() -> None:
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
    polys = [square, L_SHAPE + 5.0, square + 10.0, ARROW - 9.0]
    points, _ = _in_3d(np.concatenate(polys), 1)
    counts = np.array([len(p) for p in polys])
    corners, face = triangulate_polygons(points, counts, np.arange(len(points)))
    np.testing.assert_array_equal(face, np.repeat(np.arange(4), counts - 2))
    fan_corners, _ = _fan(counts)
    np.testing.assert_array_equal(corners[face == 0], fan_corners[:2])
    np.testing.assert_array_equal(corners[face == 2], fan_corners[6:8])
    flat = np.concatenate(polys)
    assert _signed_areas(flat, corners).sum() == pytest.approx(1.0 + 3.0 + 1.0 + 10.5)


@st.composite
def _star_polygons(draw: st.DrawFn) -> np.ndarray:
    """Simple polygons: corners at sorted angles around a centre (every gap < pi), random radii."""
    n = draw(st.integers(4, 24))
    jitter = draw(st.lists(st.floats(0.0, 0.9), min_size=n, max_size=n))
    radii = draw(st.lists(st.floats(0.2, 5.0), min_size=n, max_size=n))
    angles = 2.0 * np.pi * (np.arange(n) + np.asarray(jitter)) / n
    poly = np.stack([np.cos(angles), np.sin(angles)], axis=1) * np.asarray(radii)[:, None]
    return poly[::-1].copy() if draw(st.booleans()) else poly


@given(_star_polygons(), st.integers(0, 50))
def test_triangles_cover_exactly_the_polygon_area(poly: np.ndarray, seed: int) -> None:
    tris = _cut(poly, seed)
    polygon_area = _shoelace(poly)
    signed = _signed_areas(poly, tris)
    assert signed.sum() == pytest.approx(polygon_area, rel=1e-9)
    assert (np.sign(signed[np.abs(signed) > 1e-12]) == np.sign(polygon_area)).all()


# ---------------------------------------------------------------------------------------------
# The readers built on it: renderer, exporters (usd_geometry) and the asset library
# ---------------------------------------------------------------------------------------------


def _l_mesh(stage: Usd.Stage, path: str) -> UsdGeom.Mesh:
    """The L as one face in the z = 0 plane with per-corner normals, uv = (x, y) and a uniform colour."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray([(float(x), float(y), 0.0) for x, y in L_SHAPE]))
    mesh.CreateFaceVertexCountsAttr([6])
    mesh.CreateFaceVertexIndicesAttr(list(range(6)))
    normals = [(0.1 * k, 0.0, 1.0) for k in range(6)]  # distinct per corner, to follow the corners
    mesh.CreateNormalsAttr(Vt.Vec3fArray(normals))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying)
    primvars = UsdGeom.PrimvarsAPI(mesh)
    st_pv = primvars.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st_pv.Set(Vt.Vec2fArray([(float(x), float(y)) for x, y in L_SHAPE]))
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set([(0.2, 0.4, 0.6)])
    return mesh


def _corner_index(xy: np.ndarray) -> np.ndarray:
    """(..., 2) positions -> index of the L corner there."""
    return np.argmin(np.linalg.norm(xy[..., None, :] - L_SHAPE, axis=-1), axis=-1)


def test_primvars_follow_the_corners_of_a_concave_face() -> None:
    stage = Usd.Stage.CreateInMemory()
    mesh = _l_mesh(stage, "/L")
    topology = read_topology(mesh)
    assert topology is not None and topology.n_faces == 1
    positions = topology.points[topology.triangles]  # (T, 3, 3)
    uv = expand_primvar(np.asarray(UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st").Get(), dtype=np.float64), "faceVarying", topology)
    assert uv is not None
    np.testing.assert_allclose(uv, positions[..., :2])
    colors = expand_primvar(np.array([[0.2, 0.4, 0.6]]), "uniform", topology)
    assert colors is not None and colors.shape == (4, 3, 3)
    assert expand_primvar(np.zeros((2, 3)), "uniform", topology) is None  # 2 values for 1 face


def test_renderer_reads_concave_faces_with_their_normals() -> None:
    stage = Usd.Stage.CreateInMemory()
    mesh = _l_mesh(stage, "/L")
    world_from_local = np.eye(4)
    world_from_local[:3, 3] = [10.0, 0.0, 0.0]
    tris = mesh_triangles(mesh, world_from_local)
    assert tris is not None
    corners = tris.positions_world.reshape(-1, 3, 3)
    local_xy = corners[..., :2] - [10.0, 0.0]
    assert _signed_areas(local_xy.reshape(-1, 2), np.arange(len(corners) * 3).reshape(-1, 3)).sum() == pytest.approx(3.0)
    expected = np.array([(0.1 * k, 0.0, 1.0) for k in _corner_index(local_xy).reshape(-1)])
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(tris.normals_world, expected, atol=1e-6)
    np.testing.assert_allclose(tris.colors, np.tile([0.2, 0.4, 0.6], (len(tris.colors), 1)), atol=1e-6)


def test_exporter_reader_cuts_concave_faces_counter_clockwise() -> None:
    stage = Usd.Stage.CreateInMemory()
    arrays = read_mesh(_l_mesh(stage, "/L"))
    assert arrays is not None
    xy = arrays.points[arrays.triangles][..., :2]
    signed = _signed_areas(xy.reshape(-1, 2), np.arange(xy.shape[0] * 3).reshape(-1, 3))
    assert (signed > 0).all() and signed.sum() == pytest.approx(3.0)
    normals = np.array([(0.1 * k, 0.0, 1.0) for k in _corner_index(xy).reshape(-1)])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    np.testing.assert_allclose(arrays.corner_normals.reshape(-1, 3), normals, atol=1e-6)


def test_asset_library_cuts_concave_faces(tmp_path: Path) -> None:
    stage = Usd.Stage.CreateNew(str(tmp_path / "sign.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    root = asset_library.define_asset_root(stage, "sign")
    model = root.GetVariantSets().AddVariantSet(asset_library.VARIANT_SET)
    model.AddVariant("l")
    model.SetVariantSelection("l")
    with model.GetVariantEditContext():
        _l_mesh(stage, "/sign/Geom/plate")
    stage.GetRootLayer().Save()
    mesh = asset_library.load_mesh("sign", "l", (tmp_path,))
    assert mesh.area == pytest.approx(3.0)
    assert len(mesh.faces) == 4
    for centroid in mesh.triangles_center[:, :2]:
        assert _inside(centroid, L_SHAPE)
