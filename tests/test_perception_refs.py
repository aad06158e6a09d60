"""Detected things and segmented stuff joined into one list keep their references apart."""

from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np

from usdworld.authoring.asset_library import library_dirs
from usdworld.io.class_table import load_class_table
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Detection, Detections, InputFile, Segmentation
from usdworld.parameters.composed import DEFAULT_PARAMETERS
from usdworld.perception.objects import objects_from_detections, objects_from_segmentation
from usdworld.perception.refs import join_things_and_stuff
from usdworld.pipeline import BuildRequest, read_scene_head

SKY, SIDEWALK, BUILDING, VEGETATION, CAR = 23, 8, 11, 21, 26
FILE = InputFile("labels", "x.png", "0" * 64)


def _tree_behind_a_car() -> Segmentation:
    """A facade, and a tree whose trunk's foot (columns 155-165) a car (rows 135-170,
    columns 130-190) hides; the segmentation numbers its regions itself."""
    labels = np.full((200, 400), SKY, dtype=np.uint8)
    labels[100:, :] = SIDEWALK
    labels[60:100, 250:400] = BUILDING
    labels[40:120, 120:200] = VEGETATION
    labels[120:150, 155:165] = VEGETATION
    inst = labels.astype(np.int32)
    labels[135:170, 130:190] = CAR
    inst[135:170, 130:190] = 26000
    return Segmentation(labels, inst, (FILE,))


def _detections(*boxes: tuple[float, float, float, float]) -> list:
    file = InputFile("detections", "d.txt", "0" * 64)
    dets = Detections(tuple(Detection("Car", np.array(b)) for b in boxes), file)
    return objects_from_detections(dets, 400, 200, lookups=label_lookups())


def _joined(things: list) -> list:
    segmented = objects_from_segmentation(_tree_behind_a_car(), None, load_class_table(), label_lookups())
    return join_things_and_stuff(things, segmented)


def test_refs_are_unique_and_the_things_are_kept_as_they_were():
    things = _detections((10.0, 130.0, 60.0, 160.0), (300.0, 120.0, 360.0, 150.0), (130.0, 135.0, 190.0, 170.0))
    joined = _joined(things)
    refs = [o.ref for o in joined]
    assert len(refs) == len(set(refs))  # the segmentation's own numbers started at 1, as the detections' do
    assert [o for o in joined if o.is_thing] == things
    assert {o.class_name for o in joined if not o.is_thing} == {"building", "tree"}


def test_what_hides_the_tree_is_the_detection_of_that_car():
    segmented = objects_from_segmentation(_tree_behind_a_car(), None, load_class_table(), label_lookups())
    (tree,) = [o for o in segmented if o.class_name == "tree"]
    (seg_car,) = [o for o in segmented if o.class_name == "car"]
    assert tree.occluded_by == seg_car.ref  # the segmentation's own car hides the trunk
    things = _detections((10.0, 130.0, 60.0, 160.0), (300.0, 120.0, 360.0, 150.0), (131.0, 134.0, 190.0, 170.0))
    (joined_tree,) = [o for o in _joined(things) if o.class_name == "tree"]
    assert joined_tree.occluded_by == things[[tuple(t.box_px) for t in things].index((131, 134, 190, 170))].ref


def test_a_car_no_detection_matches_hides_nothing():
    things = _detections((10.0, 130.0, 60.0, 160.0), (150.0, 150.0, 230.0, 190.0))  # IoU with the car's box < 0.5
    (tree,) = [o for o in _joined(things) if o.class_name == "tree"]
    assert tree.occluded_by == -1


def test_stuff_hidden_by_stuff_points_at_its_new_number():
    segmented = objects_from_segmentation(_tree_behind_a_car(), None, load_class_table(), label_lookups())
    stuff = [o for o in segmented if not o.is_thing]
    faked = [replace(stuff[0], occluded_by=stuff[1].ref), *stuff[1:]]
    things = _detections((10.0, 130.0, 60.0, 160.0), (300.0, 120.0, 360.0, 150.0))
    joined = join_things_and_stuff(things, faked)
    by_source = {(o.class_name, tuple(o.box_px)): o for o in joined if not o.is_thing}
    first, second = (by_source[(o.class_name, tuple(o.box_px))] for o in faked[:2])
    assert first.occluded_by == second.ref and second.ref == stuff[1].ref + 2


def test_a_build_with_labels_and_boxes_links_the_tree_to_the_car_over_its_foot(tmp_path):
    """Through the pipeline's head: the segmentation numbers its car 1, and the detection at
    index 1 is another car, so a joined list keeping both numbers sends the tree to that one."""
    seg = _tree_behind_a_car()
    cv2.imwrite(str(tmp_path / "photo.png"), np.full((200, 400, 3), 128, np.uint8))
    cv2.imwrite(str(tmp_path / "labels.png"), seg.label_ids)
    cv2.imwrite(str(tmp_path / "instances.png"), seg.instance_ids.astype(np.uint16))
    boxes = [[10, 130, 60, 160], [300, 120, 360, 150], [131, 134, 190, 170]]
    (tmp_path / "boxes.json").write_text(
        json.dumps({"detections": [{"class": "car", "box": b, "score": 1.0} for b in boxes]})
    )
    request = BuildRequest(
        image=tmp_path / "photo.png",
        output=tmp_path / "world",
        labels=tmp_path / "labels.png",
        instances=tmp_path / "instances.png",
        detections=tmp_path / "boxes.json",
    )
    objects = read_scene_head(request, library_dirs(None), load_class_table(), DEFAULT_PARAMETERS).objects
    by_ref = {o.ref: o for o in objects}
    assert len(by_ref) == len(objects)
    (tree,) = [o for o in objects if o.class_name == "tree"]
    assert by_ref[tree.occluded_by].box_px.tolist() == boxes[2]
