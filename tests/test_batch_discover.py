"""Discovery of Cityscapes trees, KITTI object trees and manifests; resume keys.

Discovery only lists files, so most trees here hold placeholder files, not images.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from usdworld.batch.discover import (
    discover,
    discover_cityscapes,
    discover_kitti,
    discover_manifest,
    resolve_layout,
)
from usdworld.batch.frames import Frame, Incomplete, check_frame_id, make_frame
from usdworld.batch.resume import frame_key
from usdworld.errors import InputError
from usdworld.pipeline import BuildRequest


def _touch(path: Path, data: bytes = b"x") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


def _cityscapes_frame(root: Path, split: str, city: str, name: str, parts: tuple[str, ...]) -> None:
    for part in parts:
        folder = {"image": "leftImg8bit", "camera": "camera"}.get(part, "gtFine")
        suffix = {
            "image": "_leftImg8bit.png",
            "labels": "_gtFine_labelIds.png",
            "instances": "_gtFine_instanceIds.png",
            "polygons": "_gtFine_polygons.json",
            "camera": "_camera.json",
        }[part]
        _touch(root / folder / split / city / f"{name}{suffix}")


ALL = ("image", "labels", "instances", "camera")


@pytest.fixture
def cityscapes(tmp_path: Path) -> Path:
    root = tmp_path / "cs"
    _cityscapes_frame(root, "val", "bonn", "bonn_000000_000001", ALL)
    _cityscapes_frame(root, "val", "bonn", "bonn_000000_000002", ("image", "labels"))  # no instances
    _cityscapes_frame(root, "val", "bonn", "bonn_000000_000003", ("image", "polygons"))  # polygons, no camera
    _cityscapes_frame(root, "val", "bonn", "bonn_000000_000004", ("labels", "instances"))  # no image
    _cityscapes_frame(root, "val", "bonn", "bonn_000000_000005", ("image",))  # no labels at all
    _cityscapes_frame(root, "train", "aachen", "aachen_000000_000001", ALL)
    _touch(root / "leftImg8bit" / "val" / "bonn" / "notes.txt")
    _touch(root / "leftImg8bit" / "val" / "bonn" / ".DS_Store")
    return root


def test_cityscapes_frames_and_reasons(cityscapes: Path) -> None:
    items = list(discover_cityscapes(cityscapes))
    frames = {i.frame_id: i for i in items if isinstance(i, Frame)}
    reasons = {i.name: i.reason for i in items if isinstance(i, Incomplete)}
    assert list(frames) == [
        "aachen_000000_000001",
        "bonn_000000_000001",
        "bonn_000000_000003",
    ]  # train before val
    full = frames["bonn_000000_000001"].request
    gt = cityscapes / "gtFine" / "val" / "bonn"
    assert full.image == cityscapes / "leftImg8bit" / "val" / "bonn" / "bonn_000000_000001_leftImg8bit.png"
    assert (full.labels, full.instances) == (
        gt / "bonn_000000_000001_gtFine_labelIds.png",
        gt / "bonn_000000_000001_gtFine_instanceIds.png",
    )
    assert full.camera == cityscapes / "camera" / "val" / "bonn" / "bonn_000000_000001_camera.json"
    assert full.output == Path("bonn_000000_000001")
    assert frames["bonn_000000_000001"].source == "leftImg8bit/val/bonn/bonn_000000_000001_leftImg8bit.png"
    poly = frames["bonn_000000_000003"].request
    assert (poly.polygons, poly.labels, poly.camera) == (
        gt / "bonn_000000_000003_gtFine_polygons.json",
        None,
        None,
    )
    assert reasons == {
        "leftImg8bit/val/bonn/notes.txt": "not a Cityscapes image (expected <city>_<seq>_<frame>_leftImg8bit.png)",
        "bonn_000000_000002": "no gtFine/val/bonn/bonn_000000_000002_gtFine_instanceIds.png beside its labelIds "
        "(nor _gtFine_polygons.json)",
        "bonn_000000_000005": "no gtFine labels: need gtFine/val/bonn/bonn_000000_000005_gtFine_labelIds.png with "
        "_gtFine_instanceIds.png, or _gtFine_polygons.json",
        "bonn_000000_000004": "gtFine/val/bonn has labels but there is no "
        "leftImg8bit/val/bonn/bonn_000000_000004_leftImg8bit.png",
    }


def test_cityscapes_split_filter_and_errors(cityscapes: Path, tmp_path: Path) -> None:
    ids = [i.frame_id for i in discover_cityscapes(cityscapes, splits=["train"]) if isinstance(i, Frame)]
    assert ids == ["aachen_000000_000001"]
    with pytest.raises(InputError, match=r"no split 'test'; found train, val$"):
        discover_cityscapes(cityscapes, splits=["test"])
    with pytest.raises(InputError, match=r"no leftImg8bit/ folder; pass the Cityscapes root"):
        discover_cityscapes(tmp_path)


def test_cityscapes_duplicate_frame_id_is_listed(tmp_path: Path) -> None:
    _cityscapes_frame(tmp_path, "train", "bonn", "bonn_000000_000001", ALL)
    _cityscapes_frame(tmp_path, "val", "bonn", "bonn_000000_000001", ALL)
    items = list(discover_cityscapes(tmp_path))
    assert [type(i).__name__ for i in items] == ["Frame", "Incomplete"]
    assert items[1].reason == (
        "duplicate frame id 'bonn_000000_000001' (first from leftImg8bit/train/bonn/bonn_000000_000001_leftImg8bit.png)"
    )


def test_discovery_streams_without_reading_images(tmp_path: Path) -> None:
    for k in range(50):
        _cityscapes_frame(tmp_path, "val", "bonn", f"bonn_000000_{k:06d}", ALL)  # 1-byte "PNGs": never opened
    stream = discover_cityscapes(tmp_path)
    assert not isinstance(stream, list)
    first = next(iter(stream))
    assert isinstance(first, Frame) and first.frame_id == "bonn_000000_000000"


def test_kitti_frames_and_reasons(tmp_path: Path) -> None:
    for stem in ("000000", "000001", "000002"):
        _touch(tmp_path / "image_2" / f"{stem}.png")
        _touch(tmp_path / "label_2" / f"{stem}.txt")
    for stem in ("000000", "000002"):
        _touch(tmp_path / "calib" / f"{stem}.txt")
    _touch(tmp_path / "planes" / "000000.txt")
    _touch(tmp_path / "label_2" / "000009.txt")
    items = list(discover_kitti(tmp_path))
    assert [(type(i).__name__, i.frame_id if isinstance(i, Frame) else i.name) for i in items] == [
        ("Frame", "000000"),
        ("Incomplete", "000001"),
        ("Frame", "000002"),
        ("Incomplete", "000009"),
    ]
    assert items[1].reason == "no calib/000001.txt"
    assert items[3].reason == "label_2/000009.txt has no image_2/000009.png"
    request = items[0].request
    assert (request.detections, request.camera, request.ground_plane) == (
        tmp_path / "label_2" / "000000.txt",
        tmp_path / "calib" / "000000.txt",
        None,
    )
    with_planes = list(discover_kitti(tmp_path, ground_plane=True))
    assert with_planes[0].request.ground_plane == tmp_path / "planes" / "000000.txt"
    assert with_planes[2].reason == "no planes/000002.txt"


def test_manifest_json(tmp_path: Path) -> None:
    for name in ("img/a.png", "img/b.png", "gt/a_labels.png", "gt/a_inst.png", "cam/a.json"):
        _touch(tmp_path / name)
    rows = [
        {
            "id": "a",
            "image": "img/a.png",
            "labels": "gt/a_labels.png",
            "instances": "gt/a_inst.png",
            "camera": "cam/a.json",
            "max_range_m": 50,
        },
        {"image": "img/b.png", "camera": None},
        {"id": "c", "image": "img/c.png"},
        {"id": "d", "image": "img/a.png", "colour": "red"},
        {"id": "e", "image": "img/a.png", "instances": "gt/a_inst.png"},
        {"id": "a", "image": "img/b.png"},
        {"id": "../x", "image": "img/a.png"},
        "img/a.png",
    ]
    manifest = tmp_path / "frames.json"
    manifest.write_text(json.dumps(rows))
    items = list(discover_manifest(manifest, max_range_m=70.0))
    assert isinstance(items[0], Frame) and isinstance(items[1], Frame)
    assert items[0].request.labels == tmp_path / "gt" / "a_labels.png"
    assert (items[0].request.max_range_m, items[1].request.max_range_m) == (50.0, 70.0)
    assert (items[1].frame_id, items[1].source) == ("b", "img/b.png")
    assert [(i.name, i.reason) for i in items[2:]] == [
        ("c", f"frames.json -> [2] -> image: {tmp_path / 'img' / 'c.png'}: no such file"),
        (
            "d",
            (
                "frames.json -> [3]: unknown field 'colour'; use id, image, labels, instances, polygons, "
                "detections, camera, ground_plane, correspondences, depth_map, library, max_range_m"
            ),
        ),
        ("e", "frames.json -> [4]: --instances needs --labels (the labelIds PNG of the same frame)"),
        ("img/b.png", "duplicate frame id 'a' (first from img/a.png)"),
        (
            "../x",
            "frames.json -> [6]: frame id '../x': use 1-200 letters, digits, '.', '_' or '-', starting with a letter or digit",
        ),
        ("frames.json -> [7]", "frames.json -> [7]: must be an object naming the frame's files, got string"),
    ]
    manifest.write_text('{"image": "a.png"}')
    with pytest.raises(InputError, match=r"^frames.json: must be a JSON list of frame objects, got object$"):
        discover_manifest(manifest)


def test_manifest_csv(tmp_path: Path) -> None:
    _touch(tmp_path / "a.png")
    _touch(tmp_path / "a.txt")
    manifest = tmp_path / "frames.csv"
    manifest.write_text(
        "id,image,detections,camera,max_range_m\nf1,a.png,a.txt,,\nf2,a.png,,,far\nf3,a.png,,,,extra\n"
    )
    items = list(discover_manifest(manifest))
    assert isinstance(items[0], Frame)
    assert (items[0].request.detections, items[0].request.camera, items[0].request.max_range_m) == (
        tmp_path / "a.txt",
        None,
        80.0,
    )
    assert [(i.name, i.reason) for i in items[1:]] == [
        ("f2", "frames.csv line 3 -> max_range_m: must be a number, got 'far'"),
        ("frames.csv line 4", "frames.csv line 4: more cells than columns"),
    ]
    manifest.write_text("image,output\na.png,x\n")
    with pytest.raises(InputError, match=r"^frames.csv: unknown column 'output'; use id, image, "):
        discover_manifest(manifest)
    manifest.write_text("id,labels\nx,a.png\n")
    with pytest.raises(InputError, match=r"^frames.csv: no 'image' column"):
        discover_manifest(manifest)


def test_layout_resolution_and_option_checks(cityscapes: Path, tmp_path: Path) -> None:
    assert resolve_layout(tmp_path / "frames.csv", None) == "manifest"
    with pytest.raises(
        InputError,
        match=r"a folder; pass --layout cityscapes or --layout kitti \(it holds leftImg8bit/: --layout cityscapes\)$",
    ):
        resolve_layout(cityscapes, None)
    with pytest.raises(InputError, match=r"^--ground-plane applies to --layout kitti only$"):
        discover(cityscapes, "cityscapes", ground_plane=True)
    with pytest.raises(InputError, match=r"^--split applies to --layout cityscapes only$"):
        discover(tmp_path, "kitti", splits=["val"])


def test_frame_ids() -> None:
    assert check_frame_id("frankfurt_000000_000294") == "frankfurt_000000_000294"
    for bad in ("", ".hidden", "a/b", "batch.json", "x" * 201):
        with pytest.raises(InputError):
            check_frame_id(bad)
    item = make_frame("ok", "a.png", Path("a.png"), ground_plane=Path("p.txt"))
    assert isinstance(item, Incomplete) and item.reason.startswith("--ground-plane needs --camera")


def test_frame_key_hashes_content_and_options(tmp_path: Path) -> None:
    a = _touch(tmp_path / "one" / "a.png", b"image bytes")
    b = _touch(tmp_path / "two" / "b.png", b"image bytes")
    key = frame_key(BuildRequest(image=a, output=tmp_path / "out1"))
    assert len(key) == 64
    assert frame_key(BuildRequest(image=b, output=tmp_path / "out2")) == key  # paths are not part of the key
    assert frame_key(BuildRequest(image=a, output=tmp_path / "o", max_range_m=50.0)) != key
    assert frame_key(BuildRequest(image=a, output=tmp_path / "o", camera=b)) != key
    a.write_bytes(b"image byteZ")
    assert frame_key(BuildRequest(image=a, output=tmp_path / "out1")) != key
    lib = tmp_path / "lib"
    _touch(lib / "car.usda", b"v1")
    k1 = frame_key(BuildRequest(image=a, output=tmp_path / "o", library=lib))
    _touch(lib / "car.usda", b"v2")
    assert frame_key(BuildRequest(image=a, output=tmp_path / "o", library=lib)) != k1


def test_a_manifest_camera_may_be_one_camera_of_an_info_file(tmp_path: Path) -> None:
    info = _touch(tmp_path / "info.json", b'{"data_list": []}')
    _touch(tmp_path / "a.png")
    rows = [
        {"id": "a", "image": "a.png", "camera": "info.json#CAM_FRONT"},
        {"id": "b", "image": "a.png", "camera": "gone.json#CAM_FRONT"},
    ]
    (tmp_path / "frames.json").write_text(json.dumps(rows))
    a, b = list(discover(tmp_path / "frames.json"))
    assert isinstance(a, Frame) and a.request.camera == tmp_path / "info.json#CAM_FRONT"
    assert isinstance(b, Incomplete) and b.fails and b.reason.endswith("gone.json#CAM_FRONT: no such file")
    front = frame_key(replace(a.request, output=tmp_path / "o"))
    back = frame_key(replace(a.request, camera=tmp_path / "info.json#CAM_BACK"))
    assert front != back  # the camera's name is part of the key ...
    info.write_bytes(b'{"data_list": [], "x": 1}')
    assert frame_key(a.request) != front  # ... and so is the file's content
