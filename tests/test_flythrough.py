"""Fly-through: camera path, the red source vehicle in the session layer, and the MP4 itself.

Rendering tests need headless OpenGL; without it they fail with the RenderError message
naming the packages to install (they never skip).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

from usdworld.cli.main import main
from usdworld.errors import InputError, OutputError, UsdWorldError
from usdworld.parameters.video import VideoParams
from usdworld.pipeline import BuildRequest, build
from usdworld.render import RenderScene
from usdworld.render.flythrough import (
    SOURCE_VEHICLE_PATH,
    FlythroughPath,
    add_source_vehicle,
    car_asset_for,
    flythrough_poses,
    render_flythrough,
    video_intrinsics,
)
from usdworld.render.video import QUEUE_FRAMES, Mp4Writer, moov_before_mdat, read_video_frames
from usdworld.synth import make_street_scene, write_cityscapes_frame


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def _source_pose(pitch_deg: float = 3.0, roll_deg: float = 1.0, height: float = 1.5) -> np.ndarray:
    from usdworld.geometry.camera import PinholeCamera

    K = np.array([[500.0, 0, 320], [0, 500.0, 160], [0, 0, 1]])
    cam = PinholeCamera(640, 320, K, height, pitch=np.radians(pitch_deg), roll=np.radians(roll_deg), yaw=0.02)
    return cam.world_from_cam()


# -- path ----------------------------------------------------------------------------------


def test_path_starts_at_the_source_and_ends_in_the_air_looking_down() -> None:
    T0 = _source_pose()
    path = FlythroughPath()
    poses = flythrough_poses(T0, 60, path)
    assert poses.shape == (60, 4, 4)
    assert np.allclose(poses[0], T0, atol=1e-12)
    for T in poses:  # rigid, right-handed
        R = T[:3, :3]
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-9) and np.linalg.det(R) == pytest.approx(1.0)
    end = poses[-1]
    assert end[2, 3] == pytest.approx(path.aerial_height_m)
    assert end[:3, 2][2] < -0.5  # the optical axis points steeply down
    # Forward first: the camera keeps its height and orientation while it drives.
    forward = poses[: int(0.35 * 59)]
    assert np.allclose(forward[:, 2, 3], T0[2, 3]) and np.allclose(forward[:, :3, :3], T0[:3, :3])
    assert forward[-1, 0, 3] > T0[0, 3] + 5.0
    # It turns about the vertical axis: the final heading differs from the start by about turn_deg.
    h0, h1 = T0[:3, 2][:2], end[:3, 2][:2]
    turn = np.degrees(np.arccos(np.dot(h0, h1) / np.linalg.norm(h0) / np.linalg.norm(h1)))
    assert turn > 60.0


def test_path_is_smooth() -> None:
    poses = flythrough_poses(_source_pose(), 120)
    steps = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
    assert steps.max() < 1.5  # metres per frame at 120 frames
    axes = poses[:, :3, 2]
    angles = np.degrees(np.arccos(np.clip(np.sum(axes[1:] * axes[:-1], axis=1), -1, 1)))
    assert angles.max() < 4.0  # degrees per frame


def test_path_rejects_bad_arguments() -> None:
    with pytest.raises(InputError):
        flythrough_poses(_source_pose(), 1)
    with pytest.raises(InputError):
        FlythroughPath(forward_m=30.0, focus_m=25.0)


def test_video_intrinsics_keep_the_source_view_at_the_same_aspect() -> None:
    K = np.array([[560.6, 0, 507.6], [0, 560.6, 257.1], [0, 0, 1]])
    half = video_intrinsics(K, (1024, 512), (512, 256))
    assert half[0, 0] == pytest.approx(280.3) and half[1, 1] == pytest.approx(280.3)
    assert (half[0, 2] + 0.5) == pytest.approx((507.6 + 0.5) / 2) and (half[1, 2] + 0.5) == pytest.approx(
        (257.1 + 0.5) / 2
    )
    assert np.allclose(video_intrinsics(K, (1024, 512), (1024, 512)), K)


# -- video writer --------------------------------------------------------------------------


def test_mp4_writer_rejects_odd_sizes_and_wrong_frames(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="even"):
        Mp4Writer(tmp_path / "a.mp4", 33, 20)
    with pytest.raises(Exception, match="frame must be"), Mp4Writer(tmp_path / "b.mp4", 32, 20) as video:
        video.write(np.zeros((10, 10, 3), np.uint8))
    assert not (tmp_path / "b.mp4").exists() and not list(tmp_path.glob(".*"))  # partial file removed


def test_mp4_writer_keeps_the_frames_in_order_and_the_caller_may_reuse_its_array(tmp_path: Path) -> None:
    # More frames than the queue holds, written from one array the caller overwrites each time.
    levels = [(37 * i) % 256 for i in range(QUEUE_FRAMES * 3)]
    frame = np.zeros((32, 48, 3), np.uint8)
    with Mp4Writer(tmp_path / "g.mp4", 48, 32, fps=10) as video:
        for level in levels:
            frame[:] = level
            video.write(frame)
    _, frames = read_video_frames(tmp_path / "g.mp4")
    assert len(frames) == len(levels)
    assert np.allclose([f.mean() for f in frames], levels, atol=3)


def _x264_options(path: Path) -> dict[str, str]:
    """The encoder settings libx264 records in the stream (its 'options:' SEI text), by name."""
    data = path.read_bytes()
    start = data.index(b"options: ") + len(b"options: ")
    text = data[start : data.index(b"\x00", start)].decode("ascii", "replace")
    return dict(item.split("=", 1) for item in text.split() if "=" in item)


def test_mp4_writer_encodes_with_the_video_parameters(tmp_path: Path) -> None:
    frame = np.zeros((32, 48, 3), np.uint8)
    with Mp4Writer(tmp_path / "default.mp4", 48, 32) as video:
        video.write(frame)
    default = _x264_options(tmp_path / "default.mp4")
    # the preset's diamond search and one sub-pixel iteration instead of its hexagon and two
    assert (default["me"], default["subme"], default["crf"]) == ("dia", "1", "20.0")
    assert default["ref"] == "1" and default["trellis"] == "0"  # the rest is still 'veryfast'
    params = VideoParams(crf=23, preset="ultrafast", motion_search="hex", subpixel_refinement=2)
    with Mp4Writer(tmp_path / "other.mp4", 48, 32, params=params) as video:
        video.write(frame)
    other = _x264_options(tmp_path / "other.mp4")
    assert (other["me"], other["subme"], other["crf"], other["cabac"]) == ("hex", "2", "23.0", "0")


@pytest.mark.parametrize(
    "field, value",
    [
        ("crf", 52),
        ("crf", 20.5),
        ("preset", "fastest"),
        ("motion_search", "full"),
        ("subpixel_refinement", -1),
        ("shadow_taps", 2),
    ],
)
def test_video_params_reject_what_libx264_would_not_take(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=f"video.{field}"):
        VideoParams(**{field: value})


def test_mp4_writer_reports_a_dead_ffmpeg_and_leaves_no_file(tmp_path: Path) -> None:
    video = Mp4Writer(tmp_path / "d.mp4", 64, 32)
    video._gen.gi_frame.f_locals["p"].kill()  # imageio-ffmpeg's generator holds its ffmpeg process as p
    with pytest.raises(OutputError, match="ffmpeg stopped"):
        for _ in range(1000):  # the writer thread finds the broken pipe; a later write or close says so
            video.write(np.zeros((32, 64, 3), np.uint8))
        video.close()
    assert not (tmp_path / "d.mp4").exists() and not list(tmp_path.glob(".*"))


# -- rendering a world ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("fly")
    scene = make_street_scene(np.random.default_rng(4), 256, 128)
    files = write_cityscapes_frame(scene, root, "synth_000000_000004")
    return build(
        BuildRequest(
            image=files["image"],
            labels=files["labels"],
            instances=files["instances"],
            camera=files["camera"],
            output=root / "w",
        )
    ).world


def _layer_hashes(world: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in world.parent.rglob("*.usd*")}


def test_source_vehicle_is_red_and_lives_in_the_session_layer(world: Path) -> None:
    before = _layer_hashes(world)
    stage = Usd.Stage.Open(str(world))
    prim = add_source_vehicle(stage, car_asset_for(world))
    assert prim.GetPath() == SOURCE_VEHICLE_PATH
    assert stage.GetSessionLayer().GetPrimAtPath(SOURCE_VEHICLE_PATH)
    assert not stage.GetRootLayer().GetPrimAtPath(SOURCE_VEHICLE_PATH)
    assert all(not layer.dirty for layer in stage.GetLayerStack(includeSessionLayers=False))
    scene = RenderScene.from_stage(stage)
    red = np.all(np.isclose(scene.colors, [1.0, 0.0, 0.0]), axis=1)
    vehicle = (scene.object_ids == 0) & (scene.class_ids == 26)  # a car outside /World/Objects
    assert vehicle.sum() > 1000 and np.array_equal(red, vehicle)  # all of it red, nothing else
    box = (
        UsdGeom.BBoxCache(Usd.TimeCode.Default(), ["default", "render"])
        .ComputeWorldBound(prim)
        .ComputeAlignedRange()
    )
    assert box.GetMax()[0] == pytest.approx(0.5, abs=1e-4)  # bumper 0.5 m ahead of the camera's ground point
    assert abs(box.GetMin()[1] + box.GetMax()[1]) < 1e-4 and box.GetMin()[2] == pytest.approx(0.0, abs=1e-4)
    assert _layer_hashes(world) == before


def test_mp4_decodes_with_the_requested_frame_count(world: Path, tmp_path: Path) -> None:
    stage = Usd.Stage.Open(str(world))
    calls = []
    result = render_flythrough(
        stage,
        tmp_path / "fly.mp4",
        n_frames=9,
        width=96,
        height=48,
        progress=lambda d, t: calls.append((d, t)),
    )
    assert result.frames == 9 and calls[-1] == (9, 9) and len(calls) == 9
    meta, frames = read_video_frames(tmp_path / "fly.mp4")
    assert len(frames) == 9 and meta["size"] == (96, 48)
    assert meta["codec"] == "h264" and meta["pix_fmt"].startswith("yuv420p")
    assert moov_before_mdat(tmp_path / "fly.mp4")
    assert frames[0].std() > 5  # a scene, not a blank frame


def test_flythrough_command_and_bad_input(world: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "cli.mp4"
    code, stdout, err = _run(
        capsys, "flythrough", str(world), "-o", str(out), "--frames", "5", "--size", "64x32"
    )
    assert code == 0, err
    assert stdout.startswith(f"wrote {out}: 5 frames 64x32 at 30 fps, H.264 yuv420p +faststart")
    assert len(read_video_frames(out)[1]) == 5
    cases = [
        (["--size", "65x32"], "video size must be even and positive for H.264 yuv420p, got 65x32"),
        (["--frames", "1"], "--frames must be >= 2, got 1"),
        (["--size", "big"], "--size 'big': expected WIDTHxHEIGHT"),
        (["--camera", "/World/Nope"], "--camera /World/Nope: no such prim"),
    ]
    for extra, expected in cases:
        code, _, err = _run(capsys, "flythrough", str(world), "-o", str(tmp_path / "x.mp4"), *extra)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and lines[0].startswith(f"error: {expected}"), (extra, err)
    code, _, err = _run(capsys, "flythrough", str(world), "-o", str(tmp_path / "x.avi"))
    assert code == 2 and err.strip() == f"error: -o {tmp_path / 'x.avi'}: the video must be an .mp4 file"
    assert not (tmp_path / "x.mp4").exists()


def _path_view(world: Path, size: tuple[int, int], n_frames: int) -> tuple[RenderScene, np.ndarray, np.ndarray]:
    """What the fly-through draws of ``world``: its scene with the source vehicle added, the video's
    (3, 3) intrinsics at ``size`` and the (n_frames, 4, 4) world-from-camera poses of its path."""
    from usdworld.render.outputs import view_camera, world_image_size

    stage = Usd.Stage.Open(str(world))
    source_size = world_image_size(stage)
    source = view_camera(stage, *source_size)
    K = video_intrinsics(source.K, source_size, size)
    add_source_vehicle(stage, car_asset_for(world))
    return RenderScene.from_stage(stage), K, flythrough_poses(source.world_from_cam, n_frames)


def _path_frames(world: Path, taps: int, size: tuple[int, int], n_frames: int = 24, step: int = 4) -> np.ndarray:
    """(N, H, W, 3) uint8 every ``step``-th frame of the fly-through's path under the default sun (the
    world's own light is overcast), shaded with ``taps``."""
    from usdworld.render import Lighting, Renderer

    scene, K, poses = _path_view(world, size, n_frames)
    with Renderer(*size, lighting=Lighting(), shadow_taps=taps) as renderer:
        renderer.fix_shadow_box(scene, K, poses)
        return np.array([renderer.render_rgb(scene, K, pose) for pose in poses[::step]])


def test_flythrough_frames_stay_within_40_db_of_the_full_shading(world: Path) -> None:
    """The video's cheaper shadow filter changes the frames far less than the encoder does (crf 20:
    about 37 dB against the rendered frames): every frame is within 40 dB PSNR of the still's shading
    (44.9 dB here), and all together within 44 dB (46.7), yet they do differ."""
    cheap = _path_frames(world, VideoParams().shadow_taps, (384, 192)).astype(np.float64)
    full = _path_frames(world, 4, (384, 192)).astype(np.float64)
    mse = np.mean((cheap - full) ** 2, axis=(1, 2, 3))
    assert np.all(mse > 0)
    assert 10 * np.log10(255.0**2 / mse.max()) > 40.0
    assert 10 * np.log10(255.0**2 / mse.mean()) > 44.0


@pytest.mark.parametrize(("setting", "changed"), [("shadow_taps", 4), ("cull_back_faces", False), ("near_first", False)])
def test_flythrough_renders_as_the_video_parameters_say(
    world: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, setting: str, changed: object
) -> None:
    import usdworld.render.flythrough as flythrough_module

    seen: list[object] = []
    real = flythrough_module.Renderer

    def recording(*args, **kwargs):
        seen.append(kwargs[setting])
        return real(*args, **kwargs)

    monkeypatch.setattr(flythrough_module, "Renderer", recording)
    render_flythrough(Usd.Stage.Open(str(world)), tmp_path / "a.mp4", n_frames=2, width=64, height=32)
    video = VideoParams(**{setting: changed})
    render_flythrough(Usd.Stage.Open(str(world)), tmp_path / "b.mp4", n_frames=2, width=64, height=32, video=video)
    default = getattr(VideoParams(), setting)
    assert default != changed
    assert seen == [default, changed]


def test_flythrough_frames_with_back_faces_culled_keep_nearly_every_pixel(world: Path) -> None:
    """On the synthetic street's path every closed mesh is culled wherever the camera is outside its
    box; the frames differ from the whole meshes' only at depth ties and silhouette edges (< 0.05 %
    of the pixels; measured 0.003 to 0.008 % per frame here)."""
    from usdworld.render import Lighting, Renderer

    size = (384, 192)
    scene, K, poses = _path_view(world, size, 24)
    poses = poses[::4]
    frames = {}
    for cull in (True, False):
        with Renderer(*size, lighting=Lighting(), shadow_taps=1, cull_back_faces=cull) as renderer:
            renderer.fix_shadow_box(scene, K, poses)
            frames[cull] = np.array([renderer.render_rgb(scene, K, pose) for pose in poses])
            if cull:
                culled, batches = renderer.last_culled
                assert culled >= 0.9 * batches  # the synthetic street's meshes all close up
    off = np.any(frames[True] != frames[False], axis=3).mean(axis=(1, 2))
    assert off.max() < 5e-4


def test_flythrough_frames_drawn_near_first_keep_nearly_every_pixel(world: Path) -> None:
    """Near surfaces first with no depth pre-pass: the frames differ from the pre-pass's only where
    surfaces of different assets, or two instances of one mesh, tie in depth (< 0.01 % of the
    pixels; on synthetic seed 3 at 1280x640, 0 to 3 pixels a frame)."""
    from usdworld.render import Lighting, Renderer

    size = (384, 192)
    scene, K, poses = _path_view(world, size, 24)
    poses = poses[::4]
    frames = {}
    for near_first in (True, False):
        kw = {"shadow_taps": 1, "cull_back_faces": True, "near_first": near_first}
        with Renderer(*size, lighting=Lighting(), **kw) as renderer:
            renderer.fix_shadow_box(scene, K, poses)
            frames[near_first] = np.array([renderer.render_rgb(scene, K, pose) for pose in poses])
            groups = renderer._buffers.groups
            assert (renderer._buffers.last_order is not None) == near_first
    assert len(groups) < len(scene.batches)  # assets of several parts are drawn together
    off = np.any(frames[True] != frames[False], axis=3).mean(axis=(1, 2))
    assert off.max() < 1e-4


def test_gl_rows_encode_to_the_same_file_as_the_rgb_frames(world: Path, tmp_path: Path) -> None:
    """``render_rgba_rows`` (GL's RGBA rows, bottom first) into ``Mp4Writer(source="rgba_bottom_up")``
    (ffmpeg flips them) writes the very bytes that ``render_rgb``'s frames give; the rows are the
    frame's, bottom first, with alpha 255."""
    from usdworld.render import Lighting, Renderer

    size = (128, 64)
    scene, K, poses = _path_view(world, size, 12)
    with Renderer(*size, lighting=Lighting(), shadow_taps=1, cull_back_faces=True, near_first=True) as r:
        rgb = [r.render_rgb(scene, K, pose) for pose in poses]
        rows = [r.render_rgba_rows(scene, K, pose) for pose in poses]
    for frame, raw in zip(rgb, rows, strict=True):
        rgba = np.frombuffer(raw, dtype=np.uint8).reshape(size[1], size[0], 4)[::-1]
        assert np.array_equal(rgba[..., :3], frame) and np.all(rgba[..., 3] == 255)
    with Mp4Writer(tmp_path / "rgb.mp4", *size) as video:
        for frame in rgb:
            video.write(frame)
    with Mp4Writer(tmp_path / "rows.mp4", *size, source="rgba_bottom_up") as video:
        for raw in rows:
            video.write(raw)
    assert (tmp_path / "rows.mp4").read_bytes() == (tmp_path / "rgb.mp4").read_bytes()


def test_mp4_writer_takes_gl_rows_of_the_right_length_only(tmp_path: Path) -> None:
    with pytest.raises(UsdWorldError, match="source must be one of"):
        Mp4Writer(tmp_path / "x.mp4", 64, 32, source="bgr24")
    with Mp4Writer(tmp_path / "rows.mp4", 64, 32, source="rgba_bottom_up") as video:
        with pytest.raises(UsdWorldError, match="8192 RGBA bytes"):
            video.write(bytes(64 * 32 * 3))
        with pytest.raises(UsdWorldError, match="8192 RGBA bytes"):
            video.write(np.zeros((32, 64, 4), np.uint8))
        video.write(bytes(64 * 32 * 4))
    _, frames = read_video_frames(tmp_path / "rows.mp4")
    assert len(frames) == 1 and frames[0].max() <= 2  # black
