"""The detector label table: KITTI, nuScenes and COCO labels map to placed classes with their own priors."""

from __future__ import annotations

import pytest

from usdworld.errors import InputError
from usdworld.io.class_table import load_class_table
from usdworld.io.detector_labels import detector_labels, parse_detector_labels
from usdworld.io.label_table import label_lookups
from usdworld.perception.classes import placed_class_for_label

KITTI = ("Car", "Van", "Truck", "Pedestrian", "Person_sitting", "Cyclist", "Tram", "Misc")
NUSCENES = ("car", "truck", "bus", "trailer", "construction_vehicle", "pedestrian", "motorcycle", "bicycle")


def test_every_placed_label_names_a_class_of_the_table() -> None:
    table = load_class_table()
    for label, placed in detector_labels().items():
        assert placed == "" or placed in table, label


@pytest.mark.parametrize("label", KITTI + NUSCENES + ("person", "bicycle", "motorcycle", "bus", "truck", "train"))
def test_kitti_nuscenes_and_coco_labels_are_placed(label: str) -> None:
    assert placed_class_for_label(label, label_lookups()) is not None


def test_a_van_label_maps_to_the_van_class_and_gets_the_van_prior() -> None:
    table = load_class_table()
    assert placed_class_for_label("Van", label_lookups()) == "van"
    van, car = table["van"], table["car"]
    assert van.size_m == (5.07, 1.9, 2.21)  # KITTI Van mean (l, w, h)
    assert van.size_m[2] / car.size_m[2] > 1.4
    assert placed_class_for_label("Tram", label_lookups()) == "tram"
    assert table["tram"].size_m == (16.17, 2.53, 3.53)
    assert placed_class_for_label("trailer", label_lookups()) == "trailer"
    assert placed_class_for_label("construction_vehicle", label_lookups()) == "construction_vehicle"
    assert placed_class_for_label("Cyclist", label_lookups()) == "rider"


def test_known_unplaced_and_unknown_labels_are_not_placed() -> None:
    assert placed_class_for_label("traffic_cone", label_lookups()) is None
    assert placed_class_for_label("barrier", label_lookups()) is None
    assert placed_class_for_label("spaceship", label_lookups()) is None


def test_parse_errors_name_the_row() -> None:
    with pytest.raises(InputError, match="header"):
        parse_detector_labels("a,b\n")
    with pytest.raises(InputError, match="row 3: label 'car' is listed twice"):
        parse_detector_labels("label,placed_as,dataset\ncar,car,x\ncar,van,y\n")
    with pytest.raises(InputError, match="lower case"):
        parse_detector_labels("label,placed_as,dataset\nVan,van,x\n")
