"""Back-face culling of closed meshes: which winding faces out, and render_rgb with it on."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from pxr import Gf, UsdGeom, Vt
from test_render import BOX_FACES, box, camera, new_stage

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.authoring.mesh_reader import MeshTopology
from usdworld.render import Lighting, Renderer, RenderScene, sun_direction
from usdworld.render.winding import culled_face, outward_winding

W, H = 320, 200

CUBE_POINTS = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 2.0) for z in (0.0, 3.0)])


def _topology(points: np.ndarray, faces: list[list[int]]) -> MeshTopology:
    """Fan-triangulated polygons, wound as given."""
    fvi, corners, face_of_tri, start = [], [], [], 0
    for f, face in enumerate(faces):
        fvi += face
        for k in range(1, len(face) - 1):
            corners.append([start, start + k, start + k + 1])
            face_of_tri.append(f)
        start += len(face)
    return MeshTopology(
        points=np.asarray(points, dtype=np.float64),
        face_vertex_indices=np.array(fvi, dtype=np.int64),
        corners=np.array(corners, dtype=np.int64),
        face_of_tri=np.array(face_of_tri, dtype=np.int64),
        n_faces=len(faces),
        left_handed=False,
    )


def test_a_closed_box_is_wound_one_way_and_its_reverse_the_other() -> None:
    # test_render's box faces run counter-clockwise seen from outside (normals out)
    assert outward_winding(_topology(CUBE_POINTS, BOX_FACES)) == 1
    assert outward_winding(_topology(CUBE_POINTS, [f[::-1] for f in BOX_FACES])) == -1


def test_meshes_that_do_not_close_up_consistently_are_not_culled() -> None:
    assert outward_winding(_topology(CUBE_POINTS, BOX_FACES[:5])) == 0  # open: no lid
    flipped_one = [BOX_FACES[0][::-1], *BOX_FACES[1:]]
    assert outward_winding(_topology(CUBE_POINTS, flipped_one)) == 0  # one face wound the wrong way
    assert outward_winding(_topology(CUBE_POINTS, BOX_FACES + [BOX_FACES[0]])) == 0  # a face twice
    sheet = [[0, 2, 6, 4], [4, 6, 2, 0]]  # a quad and its back: closed, but encloses nothing
    assert outward_winding(_topology(CUBE_POINTS, sheet)) == 0


def test_points_split_per_face_are_welded_by_position() -> None:
    """Meshes that repeat a corner's point per face (hard normals) still close up."""
    points = np.concatenate([CUBE_POINTS[f] for f in BOX_FACES])
    faces = [[4 * i + k for k in range(4)] for i in range(6)]
    assert outward_winding(_topology(points, faces)) == 1


@settings(max_examples=25, deadline=None)
@given(
    subdivisions=st.integers(0, 2),
    scale=st.floats(0.05, 50.0),
    shift=st.tuples(*[st.floats(-100.0, 100.0)] * 3),
)
def test_spheres_face_out_wherever_they_are(
    subdivisions: int, scale: float, shift: tuple[float, ...]
) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=scale)
    points = np.asarray(sphere.vertices) + np.asarray(shift)
    faces = np.asarray(sphere.faces).tolist()
    assert outward_winding(_topology(points, faces)) == 1
    assert outward_winding(_topology(points, [f[::-1] for f in faces])) == -1


def test_a_mirroring_instance_turns_the_culled_face_over() -> None:
    eye = np.tile(np.eye(4), (3, 1, 1))
    mirror = eye.copy()
    mirror[:, 1, 1] = -1.0
    assert culled_face(1, eye) == "back" and culled_face(-1, eye) == "front"
    assert culled_face(1, mirror) == "front" and culled_face(-1, mirror) == "back"
    assert culled_face(1, np.concatenate([eye, mirror])) is None  # the instances disagree
    assert culled_face(0, eye) is None


def _street(inward_box: bool = False):
    stage = new_stage()
    box(stage, "/World/Road", (-5, -10, -0.1), (60, 10, 0), color=(0.3, 0.3, 0.3), cls="road")
    box(stage, "/World/Wall", (12, -2.5, 0), (14, 2.5, 3.0), color=(0.6, 0.5, 0.4), cls="building")
    box(stage, "/World/Post", (8, 2.0, 0), (8.2, 2.2, 2.0), color=(0.8, 0.8, 0.2), cls="pole")
    sign = UsdGeom.Mesh.Define(stage, "/World/Sign")  # an open quad: both sides show
    corners = np.array([[9, -3, 1], [9, -1, 1], [9, -1, 2.5], [9, -3, 2.5]], np.float32)
    sign.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(corners))
    sign.CreateFaceVertexCountsAttr([4])
    sign.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    sign.CreateDisplayColorAttr([Gf.Vec3f(0.2, 0.3, 0.9)])
    if inward_box:
        inward = box(stage, "/World/Inward", (20, 3, 0), (22, 5, 2), color=(0.7, 0.2, 0.2), cls="building")
        inward.CreateFaceVertexIndicesAttr([i for f in BOX_FACES for i in f[::-1]])
    return RenderScene.from_stage(stage)


K = np.array([[260.0, 0.0, 161.3], [0.0, 250.0, 83.6], [0.0, 0.0, 1.0]])


def _rgb(scene: RenderScene, cull: bool, height_m: float = 1.5, yaw: float = 0.0, tx: float = 0.0) -> tuple:
    cam = camera(K=K, height_m=height_m, pitch=0.05, roll=0.0, yaw=yaw)
    pose = cam.world_from_cam()
    pose[0, 3] += tx
    lighting = Lighting(sun_direction_world=sun_direction(20.0, 35.0), shadow_map_size=512)
    with Renderer(W, H, lighting=lighting, cull_back_faces=cull) as r:
        return r.render_rgb(scene, cam.K, pose), r.last_culled


@pytest.mark.parametrize("yaw", [0.0, 0.6, -0.8])
def test_culling_closed_meshes_keeps_every_pixel(yaw: float) -> None:
    """Seen from outside, closed boxes (wound either way) show the same surfaces with their back
    faces culled; the open quad is drawn whole (its back shows)."""
    scene = _street(inward_box=True)
    culled, counted = _rgb(scene, True, yaw=yaw)
    whole, none = _rgb(scene, False, yaw=yaw)
    assert none is None
    assert counted == (4, 5)  # road, wall, post, inward box; not the sign
    assert np.array_equal(culled, whole)


def test_a_batch_whose_box_holds_the_camera_is_drawn_whole() -> None:
    """Inside the wall's box (the near plane cuts it open) its inner faces show, as without culling."""
    scene = _street()
    culled, counted = _rgb(scene, True, height_m=1.5, tx=13.0)
    whole, _ = _rgb(scene, False, height_m=1.5, tx=13.0)
    assert counted == (2, 4)  # road and post; the wall holds the camera, the sign is open
    assert np.array_equal(culled, whole)
    assert culled.std() > 1.0  # the wall's inside is drawn (not the sky alone)


def test_render_never_culls() -> None:
    """Stills (Renderer.render) shade against the label pass's depth: nothing is culled there."""
    scene = _street()
    cam = camera(K=K, pitch=0.05, roll=0.0, yaw=0.0)
    with Renderer(W, H, cull_back_faces=True) as r:
        culled = r.render(scene, cam.K, cam.world_from_cam()).rgb
        assert r.last_culled is None
    with Renderer(W, H) as r:
        assert np.array_equal(culled, r.render(scene, cam.K, cam.world_from_cam()).rgb)
