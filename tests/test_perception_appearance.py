"""Colours measured from the photo: a known paint colour through windows, shadow, highlight and occluder."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from usdworld.evaluation.colour_difference import delta_e76
from usdworld.parameters.perception import DEFAULT_PERCEPTION
from usdworld.perception.appearance import (
    box_mean3,
    sampled_pixels,
    MeasuredColour,
    nearer_cutting_boxes,
    object_colours,
    region_colour,
    trimmed_colour,
)
from usdworld.perception.colour_space import linear_to_lab, linear_to_srgb, uint8_to_linear

PAINT = np.array([222, 184, 28], dtype=np.uint8)  # ADAC yellow, sRGB
BOX = np.array([40, 30, 200, 130])  # xmin ymin xmax ymax (max exclusive)
OCCLUDER = np.array([150, 60, 240, 150])


def _car_photo(paint: np.ndarray, window: tuple[int, int, int] = (35, 40, 45), seed: int = 0) -> np.ndarray:
    """(160, 260, 3) uint8: grey road, a car box in ``paint`` with windows, a cast shadow, a highlight
    and a blue car in front covering its right part; sensor noise on top."""
    rng = np.random.default_rng(seed)
    img = np.full((160, 260, 3), 95, dtype=np.float64)
    x0, y0, x1, y1 = BOX
    img[y0:y1, x0:x1] = paint
    img[y0 + 8 : y0 + 40, x0 + 25 : x1 - 25] = window  # rear window
    img[y1 - 22 : y1, x0:x1] = paint * 0.25  # shadow under the bumper, tyres
    img[y0 + 50 : y0 + 55, x0 + 30 : x0 + 90] = 250  # specular highlight
    a0, b0, a1, b1 = OCCLUDER
    img[b0:b1, a0:a1] = (20, 60, 170)  # the nearer car
    img += rng.normal(0.0, 3.0, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def _error(measured: MeasuredColour, paint: np.ndarray) -> float:
    return float(delta_e76(linear_to_lab(measured.linear_rgb), linear_to_lab(uint8_to_linear(paint))))


@pytest.mark.parametrize(
    "paint, window",
    [
        (PAINT, (35, 40, 45)),
        (np.array([190, 192, 196], np.uint8), (35, 40, 45)),  # silver
        # black paint in sunlight: tinted glass over a dark interior is darker still (a region whose
        # windows are brighter than its paint and cover more of it gives the windows' colour)
        (np.array([30, 30, 34], np.uint8), (10, 11, 13)),
    ],
)
def test_box_only_object_gives_its_paint_colour(paint, window):
    photo = _car_photo(paint, window)
    found = object_colours(photo, np.stack([BOX, OCCLUDER]), [None, None], np.array([12.0, 8.0]))
    assert set(found) == {0, 1}
    assert found[0].region == "box"
    assert _error(found[0], paint) < 2.0
    assert _error(found[1], np.array([20, 60, 170], np.uint8)) < 2.0
    assert np.all(
        found[0].spread < 0.03
    )  # the sensor noise (3 of 255 in sRGB) in linear RGB, not the windows


def test_a_plain_median_of_the_box_would_miss_the_paint():
    """The test above is discriminating: windows, shadow and the occluder pull a plain median away."""
    linear = uint8_to_linear(_car_photo(PAINT))
    x0, y0, x1, y1 = BOX
    plain = np.median(linear[y0:y1, x0:x1].reshape(-1, 3), axis=0)
    assert float(delta_e76(linear_to_lab(plain), linear_to_lab(uint8_to_linear(PAINT)))) > 15.0


def test_occluder_farther_away_is_not_cut_out_and_the_paint_still_wins():
    found = object_colours(_car_photo(PAINT), np.stack([BOX, OCCLUDER]), [None, None], np.array([8.0, 12.0]))
    assert _error(found[0], PAINT) < 2.0


def test_instance_mask_is_the_region_where_given():
    photo = _car_photo(PAINT)
    x0, y0, x1, y1 = BOX
    mask = np.ones((y1 - y0, x1 - x0), dtype=bool)
    mask[:, 110:] = False  # the occluder's part
    found = object_colours(photo, BOX[None], [mask], np.array([10.0]))
    assert found[0].region == "mask"
    assert _error(found[0], PAINT) < 2.0


def test_objects_with_too_few_visible_pixels_get_no_colour():
    photo = _car_photo(PAINT)
    hidden = np.array([160, 70, 170, 80])  # inside the occluder, farther than it
    found = object_colours(photo, np.stack([hidden, OCCLUDER]), [None, None], np.array([20.0, 8.0]))
    assert 0 not in found and 1 in found
    outside = object_colours(photo, np.array([[300, 0, 320, 10]]), [None], np.array([5.0]))
    assert outside == {}


def test_region_colour_of_a_labelled_surface():
    rng = np.random.default_rng(1)
    linear = np.tile(np.array([0.06, 0.06, 0.07]), (50, 80, 1)) * rng.uniform(0.95, 1.05, (50, 80, 1))
    linear[10:20] *= 0.3  # a shadow band across the road
    road = np.round(linear_to_srgb(linear) * 255).astype(np.uint8)
    region = np.ones((50, 80), dtype=bool)
    measured = region_colour(road, region, "labels")
    assert measured is not None and measured.region == "labels"
    np.testing.assert_allclose(measured.linear_rgb, [0.06, 0.06, 0.07], rtol=0.03)
    assert region_colour(road, np.zeros_like(region), "ground") is None


def test_trimmed_colour_is_order_free_and_checks_input():
    rng = np.random.default_rng(2)
    px = rng.uniform(0.2, 0.3, (500, 3))
    a = trimmed_colour(px, "mask")
    b = trimmed_colour(px[rng.permutation(500)], "mask")
    np.testing.assert_allclose(a.linear_rgb, b.linear_rgb)
    with pytest.raises(ValueError):
        trimmed_colour(np.zeros((0, 3)), "mask")
    with pytest.raises(ValueError):
        MeasuredColour(np.zeros(3), np.zeros(3), 5, "guess")


def test_body_band_leaves_out_the_side_windows_of_a_near_car():
    """A near car seen from the side: windows fill the upper part of its box, the red doors the lower."""
    rng = np.random.default_rng(3)
    img = np.full((120, 200, 3), 90.0)
    img[10:110, 0:200] = (95, 105, 120)  # windows reflecting the sky: most of the box
    img[65:100, 0:200] = (200, 30, 25)  # the doors below the belt line
    img[100:110] = (15, 15, 15)  # tyres and the shadow under the car
    photo = np.clip(img + rng.normal(0, 2, img.shape), 0, 255).astype(np.uint8)
    box = np.array([[0, 10, 200, 110]])
    whole = object_colours(photo, box, [None], np.array([4.0]))[0]
    band = object_colours(photo, box, [None], np.array([4.0]), rows=[(0.45, 0.9)])[0]
    assert _error(band, np.array([200, 30, 25], np.uint8)) < 2.0
    assert _error(whole, np.array([200, 30, 25], np.uint8)) > 20.0  # the windows win without the band


@settings(max_examples=200, deadline=None)
@given(
    boxes=st.lists(
        st.tuples(*(st.integers(-20, 120) for _ in range(4))), min_size=1, max_size=12
    ),
    depths=st.lists(st.floats(0.5, 5.0), min_size=12, max_size=12),
    i=st.integers(0, 11),
    own=st.tuples(st.integers(-20, 99), st.integers(-20, 79), st.integers(1, 40), st.integers(1, 40)),
)
def test_nearer_cutting_boxes_are_exactly_the_occluders_that_clear_a_pixel(boxes, depths, i, own):
    """Cutting every nearer box (the quadratic loop it replaces) and cutting only the ones
    returned clear the same pixels, and each one returned clears at least one pixel."""
    b = np.array(boxes, dtype=np.int64).reshape(-1, 4)
    d = np.array(depths[: len(b)], dtype=np.float64)
    i = i % len(b)
    # The object's own box always reaches into the 100 x 80 image (drawn so, not filtered).
    b[i] = (own[0], own[1], max(own[0], 0) + own[2], max(own[1], 0) + own[3])
    x0, y0, x1, y1 = max(int(b[i, 0]), 0), max(int(b[i, 1]), 0), min(int(b[i, 2]), 100), min(int(b[i, 3]), 80)
    assume(x1 > x0 and y1 > y0)

    def cut(rows: np.ndarray) -> list[np.ndarray]:
        out = []
        for a0, b0, a1, b1 in rows.tolist():
            region = np.ones((y1 - y0, x1 - x0), dtype=bool)
            region[max(b0 - y0, 0) : max(b1 - y0, 0), max(a0 - x0, 0) : max(a1 - x0, 0)] = False
            out.append(region)
        return out

    every = cut(b[d < d[i]])
    chosen = nearer_cutting_boxes(b, d, i, (x0, y0, x1, y1))
    kept = cut(chosen)
    assert all(not r.all() for r in kept)
    assert np.array_equal(
        np.logical_and.reduce(every + [np.ones((y1 - y0, x1 - x0), dtype=bool)]),
        np.logical_and.reduce(kept + [np.ones((y1 - y0, x1 - x0), dtype=bool)]),
    )


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), st.integers(1, 300), st.integers(0, 2**32 - 1))
def test_sampled_pixels_are_trimmed_colours_subsample_of_the_region(h: int, w: int, most: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    rgb = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    region = rng.random((h, w)) < 0.6
    got = sampled_pixels(rgb, region, most)
    every = rgb[region]
    expected = every if len(every) <= most else every[np.linspace(0, len(every) - 1, most).astype(np.int64)]
    assert got.dtype == np.uint8 and np.array_equal(got, expected)
    if region.any():  # the colour of the subsample decoded is the colour of every pixel decoded
        params = dataclasses.replace(DEFAULT_PERCEPTION, colour_max_samples=most)
        a = trimmed_colour(uint8_to_linear(got), "mask", params)
        b = trimmed_colour(uint8_to_linear(every), "mask", params)
        assert np.array_equal(a.linear_rgb, b.linear_rgb) and np.array_equal(a.spread, b.spread) and a.pixels == b.pixels


@settings(max_examples=80, deadline=None)
@given(st.lists(st.integers(1, 9), min_size=1, max_size=3), st.integers(0, 2**32 - 1), st.booleans())
def test_box_mean3_is_scipys_uniform_filter_bit_for_bit(shape: list[int], seed: int, counts: bool) -> None:
    from scipy.ndimage import uniform_filter  # the reference; the build no longer imports scipy

    rng = np.random.default_rng(seed)
    values = rng.poisson(3.0, size=shape).astype(np.float64) if counts else rng.random(shape) * 100.0
    assert np.array_equal(box_mean3(values), uniform_filter(values, size=3, mode="constant"))


def test_the_colour_measure_does_not_import_scipy() -> None:
    import subprocess
    import sys

    code = "import sys, usdworld.perception.appearance; print('scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _trimmed_colour_by_rows(px: np.ndarray, params=DEFAULT_PERCEPTION) -> tuple[np.ndarray, np.ndarray, int]:
    """The trimmed median as the module docstring states it, on (N, 3) rows (numpy's own median and norm)."""
    lum = px @ np.array([0.2126, 0.7152, 0.0722])
    lo, hi = np.quantile(lum, [params.colour_trim_dark, 1.0 - params.colour_trim_bright])
    kept = px[(lum >= lo) & (lum <= hi)]
    if len(kept) == 0:
        kept = px
    lab = linear_to_lab(kept)
    low = lab.min(axis=0)
    idx = np.floor((lab - low) / params.colour_bin_lab).astype(np.int64)
    shape = tuple(int(s) for s in idx.max(axis=0) + 1)
    flat = np.ravel_multi_index(tuple(idx.T), shape)
    counts = np.bincount(flat, minlength=int(np.prod(shape))).astype(np.float64)
    peak = np.array(np.unravel_index(int(np.argmax(box_mean3(counts.reshape(shape)))), shape))
    centre = lab[np.all(np.abs(idx - peak) <= 1, axis=1)].mean(axis=0)
    for _ in range(2):
        near = np.linalg.norm(lab - centre, axis=1) <= params.colour_radius_lab
        if not near.any():
            near = np.ones(len(lab), dtype=bool)
        centre = np.median(lab[near], axis=0)
    chosen = kept[near]
    median = np.median(chosen, axis=0)
    return np.clip(median, 0.0, 1.0), 1.4826 * np.median(np.abs(chosen - median), axis=0), len(chosen)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 400), st.integers(1, 4))
def test_trimmed_colour_channel_by_channel_is_the_row_wise_measure_bit_for_bit(
    seed: int, n: int, clusters: int
) -> None:
    # a few colour clusters with noise, as an object's pixels are
    rng = np.random.default_rng(seed)
    centres = rng.integers(0, 256, size=(clusters, 3))
    noisy = centres[rng.integers(0, clusters, n)] + rng.normal(0, 12, (n, 3))
    codes = np.clip(noisy, 0, 255).astype(np.uint8)
    px = uint8_to_linear(codes)
    got = trimmed_colour(px, "mask")
    median, spread, count = _trimmed_colour_by_rows(px)
    assert np.array_equal(got.linear_rgb, median) and np.array_equal(got.spread, spread)
    assert got.pixels == count
