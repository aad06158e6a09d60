"""The ``hf`` segmentation backend: tiny random transformers models built here, loaded offline,
run through ``usdworld segment`` and ``usdworld build --segment hf``; models whose output is
known pin what the pipeline places from it."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from synthetic_scene import default_camera, default_objects, draw, write_scene

from hf_support import refuse_network
from usdworld.cli.main import main
from usdworld.io.label_table import by_name
from usdworld.io.labels import read_segmentation

torch = pytest.importorskip("torch", reason="torch is not installed (pip install torch==2.13.0)")
transformers = pytest.importorskip(
    "transformers", reason="transformers is not installed (pip install transformers==5.23.0); hf backend untested"
)

from usdworld.perception.segment.hf import HfSegmentBackend  # noqa: E402

CITYSCAPES_19 = (
    "road", "sidewalk", "building", "wall", "fence", "pole", "traffic light", "traffic sign", "vegetation",
    "terrain", "sky", "person", "rider", "car", "truck", "bus", "train", "motorcycle", "bicycle",
)  # fmt: skip
ID2LABEL = dict(enumerate(CITYSCAPES_19))
CAMERA = default_camera(640, 320)


@pytest.fixture(autouse=True)
def offline(monkeypatch: pytest.MonkeyPatch) -> None:
    """No hub access: offline flags set and every socket connection refused."""
    refuse_network(monkeypatch)


def _processor(name: str, **kwargs: object):
    return (getattr(transformers, f"{name}ImageProcessorPil", None) or getattr(transformers, f"{name}ImageProcessor"))(
        size={"height": 64, "width": 64}, **kwargs
    )


@pytest.fixture(scope="module")
def tiny_segformer(tmp_path_factory: pytest.TempPathFactory) -> Path:
    torch.manual_seed(0)
    folder = tmp_path_factory.mktemp("tiny-segformer")
    config = transformers.SegformerConfig(
        num_encoder_blocks=4, depths=[1, 1, 1, 1], sr_ratios=[8, 4, 2, 1], hidden_sizes=[8, 8, 16, 16],
        num_attention_heads=[1, 1, 1, 1], mlp_ratios=[2, 2, 2, 2], decoder_hidden_size=8,
        id2label=ID2LABEL, label2id={v: k for k, v in ID2LABEL.items()},
    )  # fmt: skip
    transformers.SegformerForSemanticSegmentation(config).save_pretrained(folder)
    _processor("Segformer").save_pretrained(folder)
    return folder


@pytest.fixture(scope="module")
def tiny_mask2former(tmp_path_factory: pytest.TempPathFactory) -> Path:
    torch.manual_seed(0)
    folder = tmp_path_factory.mktemp("tiny-mask2former")
    backbone = transformers.SwinConfig(
        image_size=64, patch_size=4, embed_dim=8, depths=[1, 1, 1, 1], num_heads=[1, 1, 1, 1], window_size=2,
        out_features=["stage1", "stage2", "stage3", "stage4"],
    )  # fmt: skip
    config = transformers.Mask2FormerConfig(
        backbone_config=backbone, feature_size=32, mask_feature_size=32, hidden_dim=32, encoder_feedforward_dim=32,
        dim_feedforward=32, encoder_layers=1, decoder_layers=2, num_attention_heads=2, num_queries=8,
        id2label=ID2LABEL, label2id={v: k for k, v in ID2LABEL.items()},
    )  # fmt: skip
    transformers.Mask2FormerForUniversalSegmentation(config).save_pretrained(folder)
    _processor("Mask2Former").save_pretrained(folder)
    return folder


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return write_scene(tmp_path_factory.mktemp("segment-scene"), CAMERA)


def _truth() -> tuple[np.ndarray, np.ndarray]:
    _, labels, instances = draw(CAMERA, default_objects())
    return labels, instances


def _model_index(labels: np.ndarray) -> np.ndarray:
    """(H, W) Cityscapes label ids -> index into CITYSCAPES_19 (the synthetic scene uses only those)."""
    lut = np.full(256, -1)
    for i, name in enumerate(CITYSCAPES_19):
        lut[by_name(name).id] = i
    index = lut[labels]
    assert (index >= 0).all()
    return index


def _semantic_output(self: HfSegmentBackend, rgb: np.ndarray):
    """What a perfect semantic model returns for the synthetic scene: one-hot logits of its labels."""
    index = torch.from_numpy(_model_index(_truth()[0]))
    logits = torch.nn.functional.one_hot(index, len(CITYSCAPES_19)).permute(2, 0, 1)[None].float() * 10.0
    return transformers.modeling_outputs.SemanticSegmenterOutput(logits=logits)


def _panoptic_output(self: HfSegmentBackend, rgb: np.ndarray):
    """What a perfect Mask2Former returns: a query per stuff class and per object, sure of its class."""
    labels, instances = _truth()
    index = _model_index(labels)
    segments = sorted(set(np.unique(instances).tolist()))
    classes = torch.full((1, len(segments), len(CITYSCAPES_19) + 1), -10.0)
    masks = torch.full((1, len(segments), *labels.shape), -10.0)
    for q, seg_id in enumerate(segments):
        on = instances == seg_id
        classes[0, q, int(index[on][0])] = 10.0
        masks[0, q][torch.from_numpy(on)] = 10.0
    from transformers.models.mask2former.modeling_mask2former import Mask2FormerForUniversalSegmentationOutput

    return Mask2FormerForUniversalSegmentationOutput(class_queries_logits=classes, masks_queries_logits=masks)


def _run(capsys: pytest.CaptureFixture[str], *args: object) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _objects(world: Path) -> list[tuple[str, float, float]]:
    report = json.loads((world / "report.json").read_text())
    return sorted((o["class"], *o["position_world"][:2]) for o in report["objects"])


@pytest.mark.parametrize("model", ["tiny_segformer", "tiny_mask2former"])
def test_random_models_run_end_to_end_and_the_world_validates(model, request, scene, tmp_path, capsys) -> None:
    folder = request.getfixturevalue(model)
    code, out, err = _run(capsys, "segment", scene["image"], "--segment-model", folder, "-o", tmp_path / "seg")
    assert code == 0, err
    stem = scene["image"].stem
    seg = read_segmentation(tmp_path / "seg" / f"{stem}_labelIds.png", tmp_path / "seg" / f"{stem}_instanceIds.png")
    assert seg.label_ids.shape == (CAMERA.height, CAMERA.width) and seg.instance_ids is not None
    preview = cv2.imread(str(tmp_path / "seg" / f"{stem}_color.png"))
    assert preview.shape == (CAMERA.height, CAMERA.width, 3)
    assert out.splitlines()[-3:] == [f"wrote {tmp_path / 'seg' / stem}{s}.png" for s in ("_labelIds", "_instanceIds", "_color")]
    world = tmp_path / "w"
    code, _, err = _run(capsys, "build", scene["image"], "--camera", scene["camera"], "--segment", "hf",
                        "--segment-model", folder, "-o", world)  # fmt: skip
    assert code == 0, err
    inputs = json.loads((world / "report.json").read_text())["inputs"]
    assert {"role": "segment_model", "name": folder.name} in [{k: i[k] for k in ("role", "name")} for i in inputs]
    assert _run(capsys, "validate", world)[0] == 0


def test_semantic_model_output_places_the_objects_of_its_labels(scene, tiny_segformer, tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setattr(HfSegmentBackend, "_run_model", _semantic_output)
    seg_dir = tmp_path / "seg"
    assert _run(capsys, "segment", scene["image"], "--segment-model", tiny_segformer, "-o", seg_dir)[0] == 0
    stem = scene["image"].stem
    labels, instances = seg_dir / f"{stem}_labelIds.png", seg_dir / f"{stem}_instanceIds.png"
    seg = read_segmentation(labels, instances)
    truth_labels, _ = _truth()
    assert np.array_equal(seg.label_ids, truth_labels)
    # Connected components: two of the five cars touch in the image and become one object.
    things = np.unique(seg.instance_ids[seg.instance_ids >= 1000]) // 1000
    assert sorted(things.tolist()) == [24] * 3 + [26] * 4 + [27]
    code, _, err = _run(capsys, "build", scene["image"], "--camera", scene["camera"], "--segment", "hf",
                        "--segment-model", tiny_segformer, "-o", tmp_path / "w")  # fmt: skip
    assert code == 0, err
    placed = _objects(tmp_path / "w")
    assert [c for c, *_ in placed] == ["car"] * 4 + ["person"] * 3 + ["truck"]
    # The maps `usdworld segment` wrote give the same world through --labels / --instances.
    assert _run(capsys, "build", scene["image"], "--camera", scene["camera"], "--labels", labels,
                "--instances", instances, "-o", tmp_path / "w2")[0] == 0  # fmt: skip
    assert _objects(tmp_path / "w2") == placed


def test_detection_boxes_split_touching_things_of_a_semantic_model(scene, tiny_segformer, tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setattr(HfSegmentBackend, "_run_model", _semantic_output)
    _, truth = _truth()
    dets = []
    for iid in np.unique(truth[truth >= 1000]):
        v, u = np.nonzero(truth == iid)
        name = {24: "person", 26: "car", 27: "truck"}[int(iid) // 1000]
        dets.append({"class": name, "box": [int(u.min()), int(v.min()), int(u.max()) + 1, int(v.max()) + 1]})
    det_file = tmp_path / "dets.json"
    det_file.write_text(json.dumps({"detections": dets}))
    code, _, err = _run(capsys, "segment", scene["image"], "--segment-model", tiny_segformer, "--detections", det_file,
                        "-o", tmp_path / "seg")  # fmt: skip
    assert code == 0, err
    stem = scene["image"].stem
    inst = cv2.imread(str(tmp_path / "seg" / f"{stem}_instanceIds.png"), cv2.IMREAD_UNCHANGED)
    things = np.unique(inst[inst >= 1000]) // 1000
    assert sorted(things.tolist()) == [24] * 3 + [26] * 5 + [27]  # the two touching cars are two again


def test_panoptic_model_output_places_the_objects_of_the_truth(scene, tiny_mask2former, tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setattr(HfSegmentBackend, "_run_model", _panoptic_output)
    code, _, err = _run(capsys, "build", scene["image"], "--camera", scene["camera"], "--segment", "hf",
                        "--segment-model", tiny_mask2former, "-o", tmp_path / "w")  # fmt: skip
    assert code == 0, err
    assert _run(capsys, "build", scene["image"], "--camera", scene["camera"], "--labels", scene["labels"],
                "--instances", scene["instances"], "-o", tmp_path / "truth")[0] == 0  # fmt: skip
    placed, truth = _objects(tmp_path / "w"), _objects(tmp_path / "truth")
    assert [c for c, *_ in placed] == [c for c, *_ in truth] == ["car"] * 5 + ["person"] * 3 + ["truck"]
    for cls, x, y in truth:  # each object of the truth build has its own match, within 0.3 m
        near = [i for i, (c, px, py) in enumerate(placed) if c == cls and np.hypot(px - x, py - y) < 0.3]
        assert len(near) == 1, (cls, x, y, placed)
        placed.pop(near[0])


def test_unknown_class_names_are_unlabelled_and_counted_in_a_warning(tiny_segformer, tmp_path, monkeypatch, caplog) -> None:
    import shutil

    from usdworld.io.images import read_image
    from usdworld.segment_stage import segment_photo

    folder = tmp_path / "renamed"
    shutil.copytree(tiny_segformer, folder)
    config = json.loads((folder / "config.json").read_text())
    config["id2label"]["0"] = "zebra crossing"  # road, renamed to a class no table knows
    (folder / "config.json").write_text(json.dumps(config))
    monkeypatch.setattr(HfSegmentBackend, "_run_model", _semantic_output)
    image_path = tmp_path / "photo.png"
    cv2.imwrite(str(image_path), np.zeros((CAMERA.height, CAMERA.width, 3), np.uint8))
    with caplog.at_level("WARNING"):
        seg = segment_photo("hf", folder, read_image(image_path))
    truth_labels, _ = _truth()
    road = truth_labels == by_name("road").id
    assert (seg.label_ids[road] == 0).all() and np.array_equal(seg.label_ids[~road], truth_labels[~road])
    assert f"{road.sum()} pixels of 1 classes not in the segmentation label table were left unlabeled: zebra crossing ({road.sum()} px)" in caplog.text


def test_oneformer_is_refused_with_the_reason(tmp_path, capsys) -> None:
    folder = tmp_path / "oneformer"
    folder.mkdir()
    transformers.OneFormerConfig().save_pretrained(folder)
    image = tmp_path / "p.png"
    cv2.imwrite(str(image), np.zeros((8, 8, 3), np.uint8))
    code, _, err = _run(capsys, "segment", image, "--segment-model", folder, "-o", tmp_path / "s")
    assert code == 2 and err.count("\n") == 1 and "OneFormer is not supported: its processor fetches" in err, err
