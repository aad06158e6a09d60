"""Known answers of the facade cuts and the crown cuts on small hand-made label maps.

Each test builds a region whose right cut follows from its construction, checks the
cut, and checks that without the rule (its threshold switched off, or its input taken
away) the cut is not made: the answer comes from that rule.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from usdworld.io.class_table import load_class_table
from usdworld.io.label_table import label_lookups
from usdworld.io.types import Segmentation
from usdworld.parameters import PerceptionParams
from usdworld.perception.crowns import crown_ranges
from usdworld.perception.facades import StreetView, facade_ranges
from usdworld.perception.objects import objects_from_segmentation

PARAMS = PerceptionParams()
#: The horizon 3 px above every facade base below: a level camera 1.5 m high sees the base
#: ``Z = f h / 3 px`` ahead, so each column spans ``Z / f = 1.5 / 3 = 0.5 m`` of frontage.
BASE_BELOW_HORIZON_PX = 3.0
CAMERA_HEIGHT_M = 1.5
M_PER_COLUMN = CAMERA_HEIGHT_M / BASE_BELOW_HORIZON_PX


def _flat_facade(tops: list[int], h: int) -> np.ndarray:
    """(h, len(tops)) bool crop: column c is facade from row tops[c] to the bottom."""
    rows = np.arange(h)[:, None]
    return rows >= np.asarray(tops)[None, :]


def _view(y0: int, h: int) -> StreetView:
    """A level view whose horizon lies BASE_BELOW_HORIZON_PX above the crop's base edge."""
    return StreetView(y0 + h - BASE_BELOW_HORIZON_PX, 100.0, 0.0, CAMERA_HEIGHT_M)


def test_facade_cut_at_the_roofline_step():
    # Two buildings of 20 columns (10 m each) with their roofs 10 px apart.
    step_at, width, h, x0, y0 = 20, 40, 30, 5, 10  # x0 > 0: the run does not touch the image's side
    tops = [5] * step_at + [15] * (width - step_at)
    mask = _flat_facade(tops, h)
    on_ground = np.ones(width, dtype=bool)
    # The step (10 px) exceeds max(roof_step_min_px, roof_step_fraction * 15 px): a new building.
    assert 10 > max(PARAMS.roof_step_min_px, PARAMS.roof_step_fraction * (h - 15))
    # Each is one piece: 10 m rounds to one roofline frontage (16 m), and is >= min_piece_m.
    assert round(step_at * M_PER_COLUMN / PARAMS.roofline_frontage_m) == 1
    ranges = facade_ranges(mask, x0, y0, on_ground, _view(y0, h), 1.0, params=PARAMS)
    assert ranges == [(0, step_at), (step_at, width)]
    # Without the roofline rule the 20 m run is one building (20 m / 16 m rounds to 1).
    no_steps = dataclasses.replace(PARAMS, roof_step_min_px=10**6)
    assert facade_ranges(mask, x0, y0, on_ground, _view(y0, h), 1.0, params=no_steps) == [(0, width)]


def test_facade_running_out_of_the_image_keeps_its_seen_end():
    # A 61-column run (30.5 m) whose roof is out of view (its top at the image's top row).
    # The frontage is set so that no cut falls on a column boundary (rounding-proof).
    width, h = 61, 20
    params = dataclasses.replace(PARAMS, frontage_m=12.2)
    mask = _flat_facade([0] * width, h)
    on_ground = np.ones(width, dtype=bool)
    view = _view(0, h)
    total, frontage = width * M_PER_COLUMN, params.frontage_m

    def bounds(metres: list[float]) -> list[tuple[int, int]]:
        """Ranges cut after the column in which each distance from the left end falls."""
        cuts = [int(np.ceil(m / M_PER_COLUMN)) for m in metres]
        return list(zip([0, *cuts], [*cuts, width]))

    # Cut by the left side: whole buildings are measured from the seen right end, every
    # frontage; what is left at the side (6.1 m) is the seen part of one more.
    out_left = facade_ranges(mask, 0, 0, on_ground, view, 1.0, image_width=200, params=params)
    assert out_left == bounds([total - 2 * frontage, total - frontage]) == [(0, 13), (13, 37), (37, 61)]
    # Cut by the right side: from the seen left end.
    out_right = facade_ranges(mask, 200 - width, 0, on_ground, view, 1.0, image_width=200, params=params)
    assert out_right == bounds([frontage, 2 * frontage]) == [(0, 25), (25, 49), (49, 61)]
    # Seen whole, the same run is cut into equal pieces: round(30.5 / 12.2) = 2.
    inside = facade_ranges(mask, 70, 0, on_ground, view, 1.0, image_width=200, params=params)
    assert inside == bounds([total / 2])


def _street_sides(vanishing_u: int, width: int) -> np.ndarray:
    """Label ids: a facade on each side of the street, both running into its vanishing point
    (base and roof converge on the horizon row 40 there), sidewalk below, sky above."""
    lk = label_lookups()
    labels = np.full((width, width), lk.id_of("sky"), dtype=np.uint8)
    labels[41:] = lk.id_of("sidewalk")
    for u in range(width):
        spread = int(np.floor(0.6 * abs(u + 0.5 - vanishing_u)))
        labels[38 - spread : 42 + spread, u] = lk.id_of("building")
    return labels


def test_facade_cut_at_the_streets_vanishing_point():
    vp, width = 50, 100
    labels = _street_sides(vp, width)
    view = StreetView(40.0, 100.0, float(vp), CAMERA_HEIGHT_M, vanishing_u=float(vp))
    lk = label_lookups()
    objects = objects_from_segmentation(Segmentation(labels, None, ()), view, load_class_table(), lk, PARAMS)
    spans = sorted((int(o.box_px[0]), int(o.box_px[2])) for o in objects if o.class_name == "building")
    left = [s for s in spans if s[1] <= vp]
    right = [s for s in spans if s[0] >= vp]
    # Every building stands on one side, and the two sides, built as mirror images about
    # the vanishing point's column, are cut as mirror images.
    assert left and right and len(left) + len(right) == len(spans)
    assert sorted((2 * vp - b, 2 * vp - a) for a, b in left) == right
    assert left[0][0] == 0 and right[-1][1] == width
    # Without the cut at the vanishing point the region is measured as one wall: a piece
    # crosses the vanishing point's column.
    mask = labels == lk.id_of("building")
    rows = np.nonzero(mask.any(axis=1))[0]
    whole = facade_ranges(
        mask[rows[0] : rows[-1] + 1], 0, int(rows[0]), np.ones(width, bool), view, 1.0, image_width=width
    )
    assert any(a < vp < b for a, b in whole)


def test_two_crowns_cut_at_the_dip_between_their_tops():
    # Crown tops at columns 10 and 30, 20 and 16 px high, their outlines falling 1 px per
    # column: they meet where 20 - (c - 10) = 16 - (30 - c), at c = 22.
    (a, ha), (b, hb), width = (10, 20), (30, 16), 41
    outline = [max(ha - abs(c - a), hb - abs(c - b)) for c in range(width)]
    h = max(outline)
    mask = np.arange(h)[:, None] >= h - np.asarray(outline)[None, :]
    dip = (ha - hb + a + b) // 2
    assert outline[dip] == min(outline[a : b + 1])
    assert crown_ranges(mask, params=PARAMS) == [(0, dip), (dip, width)]
    # The smaller crown rises hb - outline[dip] = 8 px above the dip; with a prominence
    # threshold above that, there is one crown.
    one_top = dataclasses.replace(PARAMS, crown_prominence_px=hb - outline[dip] + 1.0)
    assert crown_ranges(mask, params=one_top) == [(0, width)]


def test_more_trunks_than_tops_cut_between_the_trunks():
    # One flat crown top over the whole region; its hem hangs 10 px above the ground, 12 px
    # over columns 18-20 where two crowns meet; two trunks (columns 7-9 and 31-33) reach the ground.
    width, h = 41, 30
    hem = np.full(width, 10)
    hem[18:21] = 12
    hem[7:10] = 0
    hem[31:34] = 0
    mask = np.arange(h)[:, None] < (h - hem)[None, :]
    cut = 19  # the middle of the highest run of the hem between the trunks
    on_ground = np.ones(width, dtype=bool)
    assert crown_ranges(mask, on_ground, PARAMS) == [(0, cut), (cut, width)]
    # Feet count only where they stand on the ground (or on a thing hiding the trunk):
    assert crown_ranges(mask, None, PARAMS) == [(0, width)]
    assert crown_ranges(mask, np.zeros(width, dtype=bool), PARAMS) == [(0, width)]
