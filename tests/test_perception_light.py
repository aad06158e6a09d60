"""The sun and sky from a photo: swept footprints, the fit on a drawn street, sunny or overcast, sky colours."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.geometry.camera import PinholeCamera
from usdworld.parameters.light import LightParams
from usdworld.perception.colour_space import linear_to_srgb, uint8_to_linear
from usdworld.perception.light import (
    ShadowCaster,
    _hull,
    _overlap,
    _overlaps,
    _Pairs,
    _pairs,
    _predicted_sets,
    _Samples,
    _Strip,
    _strip,
    _strip_in_shadow,
    _strips,
    estimate_light,
    half_planes,
    in_swept,
    inner_ground,
    inner_ids_at,
    inside_convex,
    median_linear,
    present_ids,
    reference_stride,
    sky_colours,
    sweep_entry,
)

PARAMS = LightParams()
SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def _swept(points: np.ndarray, footprint: np.ndarray, sweep: np.ndarray) -> np.ndarray:
    a, b = half_planes(_hull(footprint))
    slack = points @ a.T - b
    rate = np.broadcast_to(a @ sweep, slack.shape)
    return in_swept(slack, rate)


def test_swept_square_known_answer() -> None:
    points = np.array([[2.5, 0.5], [3.5, 0.5], [0.5, 1.5], [0.5, 0.5], [2.9, 0.99], [-0.1, 0.5]])
    assert _swept(points, SQUARE, np.array([2.0, 0.0])).tolist() == [True, False, False, True, True, False]


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-3, 3),
    st.floats(-3, 3),
    st.floats(0.3, 3),
    st.floats(0.3, 2),
    st.floats(-math.pi, math.pi),
    st.lists(st.tuples(st.floats(-6, 6), st.floats(-6, 6)), min_size=1, max_size=20),
)
def test_swept_footprint_is_the_hull_of_the_footprint_and_its_shadow_end(
    sx: float, sy: float, length: float, width: float, yaw: float, pts: list
) -> None:
    c, s = math.cos(yaw), math.sin(yaw)
    footprint = (np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]) @ np.array([[c, -s], [s, c]]).T
    sweep = np.array([sx, sy])
    points = np.array(pts, dtype=np.float64)
    hull = _hull(np.concatenate([footprint, footprint + sweep]))
    expected = inside_convex(points, hull)
    # points within a micrometre of the outline may go either way
    near_edge = inside_convex(points, hull, 1e-6) & ~inside_convex(points, hull, -1e-6)
    got = _swept(points, footprint, sweep)
    assert np.array_equal(got[~near_edge], expected[~near_edge])


W, H = 640, 360
CAMERA = PinholeCamera(
    width=W, height=H, K=np.array([[400.0, 0, 320], [0, 400.0, 180], [0, 0, 1]]), height_m=1.5, pitch=0.06, roll=0.0, yaw=0.0
)
#: Cars and posts ahead of the camera, both sides of the road.
CASTERS = [
    ShadowCaster(f"car_{i}", np.array([[x - 2, y - 0.9], [x + 2, y - 0.9], [x + 2, y + 0.9], [x - 2, y + 0.9]]), 1.5)
    for i, (x, y) in enumerate([(10.0, 3.0), (14.0, -3.5), (20.0, 2.0), (25.0, -2.5), (8.0, -4.0)])
] + [
    ShadowCaster(f"pole_{i}", np.array([[x - 0.1, y - 0.1], [x + 0.1, y - 0.1], [x + 0.1, y + 0.1], [x - 0.1, y + 0.1]]), 5.0)
    for i, (x, y) in enumerate([(12.0, 6.0), (18.0, -6.5)])
]


def _street(
    sun_azimuth_deg: float | None, sun_elevation_deg: float, casters: list[ShadowCaster] = CASTERS
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A flat grey street seen by CAMERA: (H, W, 3) photo, (H, W) ground ids, ground_from_px.

    The casters' footprints are not ground (the objects stand there); their shadows, drawn
    as the hull of each footprint and the footprint moved away from the sun, are 4 times
    darker than the lit ground. ``sun_azimuth_deg`` None: no shadows (overcast).
    """
    ground_from_px = np.linalg.inv(CAMERA.px_from_ground())
    v, u = np.mgrid[0:H, 0:W]
    px = np.column_stack([u.ravel() + 0.5, v.ravel() + 0.5, np.ones(u.size)])
    g = px @ ground_from_px.T
    below = (v.ravel() > CAMERA.horizon_v() + 2) & (g[:, 2] * np.sign(g[:, 2]).max() > 0)
    ground = np.zeros(u.size, dtype=np.int32)
    ground[below] = 1
    pts = np.zeros((u.size, 2))
    pts[below] = g[below, :2] / g[below, 2:3]
    linear = np.full(u.size, 0.3)
    for c in casters:
        ground[below & inside_convex(pts, _hull(c.footprint_ground))] = 0
        if sun_azimuth_deg is not None:
            length = c.height_m / math.tan(math.radians(sun_elevation_deg))
            away = -length * np.array([math.cos(math.radians(sun_azimuth_deg)), math.sin(math.radians(sun_azimuth_deg))])
            shadow = _hull(np.concatenate([c.footprint_ground, c.footprint_ground + away]))
            linear[below & inside_convex(pts, shadow)] = 0.3 / 4.0
    srgb = np.round(linear_to_srgb(linear) * 255).astype(np.uint8).reshape(H, W)
    rgb = np.repeat(srgb[:, :, None], 3, axis=2)
    return rgb, ground.reshape(H, W), ground_from_px


@pytest.mark.parametrize(("azimuth", "elevation"), [(140.0, 45.0), (-150.0, 30.0), (120.0, 52.0)])
def test_sun_is_found_from_drawn_shadows(azimuth: float, elevation: float) -> None:
    rgb, ground, ground_from_px = _street(azimuth, elevation)
    est = estimate_light(rgb, ground, np.zeros((H, W), bool), "labels", CASTERS, ground_from_px, 0.5, 0.5, PARAMS)
    assert est.method == "cast_shadows" and not est.overcast
    # the ring around a car is sampled under a metre apart: a 1.2 m shadow turns a few degrees within it
    error = (math.degrees(est.sun_azimuth) - azimuth + 180.0) % 360.0 - 180.0
    assert abs(error) <= 5.0
    assert abs(math.degrees(est.sun_elevation) - elevation) <= 5.0
    assert est.shadow_contrast == pytest.approx(4.0, rel=0.1)
    assert est.sun_direction_world[2] == pytest.approx(math.sin(est.sun_elevation))


def test_no_shadows_means_overcast_and_no_casters_means_no_evidence() -> None:
    rgb, ground, ground_from_px = _street(None, 45.0)
    est = estimate_light(rgb, ground, np.zeros((H, W), bool), "labels", CASTERS, ground_from_px, 0.5, 0.6, PARAMS)
    assert (est.method, est.overcast, est.shadow_share) == ("overcast", True, 0.0)
    assert (est.sun_azimuth, est.sun_elevation) == (0.5, 0.6)  # the caller's default
    est = estimate_light(rgb, ground, np.zeros((H, W), bool), "labels", [], ground_from_px, 0.5, 0.6, PARAMS)
    assert (est.method, est.overcast, est.casters) == ("no_evidence", False, 0)
    assert est.sky_source == "none" and np.all(np.isnan(est.sky_zenith_linear))


def test_sky_colours_are_the_medians_of_its_top_and_bottom_rows() -> None:
    rgb = np.zeros((40, 10, 3), dtype=np.uint8)
    rgb[:10] = (60, 120, 240)
    rgb[10:30] = (150, 170, 200)
    rgb[30:] = (200, 200, 210)
    sky = np.zeros((40, 10), bool)
    sky[:40] = True
    zenith, horizon = sky_colours(rgb, sky, LightParams(sky_top_fraction=0.25))
    assert np.allclose(linear_to_srgb(zenith) * 255, (60, 120, 240), atol=0.5)
    assert np.allclose(linear_to_srgb(horizon) * 255, (200, 200, 210), atol=0.5)


def test_one_casters_shadow_is_a_weak_fit_and_gives_the_default_sun() -> None:
    # one car's shadow fits well, but one shadow is one direction and one length: not trusted
    car = CASTERS[:1]
    rgb, ground, ground_from_px = _street(140.0, 45.0, car)
    est = estimate_light(rgb, ground, np.zeros((H, W), bool), "labels", car, ground_from_px, 0.5, 0.6, PARAMS)
    assert (est.method, est.overcast, est.fit_casters) == ("weak_fit", False, 1)
    assert est.fit_iou > PARAMS.min_fit_iou  # the fit itself is good
    assert (est.sun_azimuth, est.sun_elevation) == (0.5, 0.6)  # the caller's default
    # the same car next to a second caster whose shadow agrees: trusted
    two = CASTERS[:1] + CASTERS[5:6]
    rgb, ground, ground_from_px = _street(140.0, 45.0, two)
    est = estimate_light(rgb, ground, np.zeros((H, W), bool), "labels", two, ground_from_px, 0.5, 0.6, PARAMS)
    assert (est.method, est.fit_casters) == ("cast_shadows", 2)
    assert abs((math.degrees(est.sun_azimuth) - 140.0 + 180.0) % 360.0 - 180.0) <= 5.0


def test_shadows_the_casters_do_not_explain_are_a_weak_fit() -> None:
    # the shadows are those of objects 5 m along and 4 m across from the casters (unseen ones,
    # or placements that are far off): no sun explains them well, so the fit is not trusted
    moved = [ShadowCaster(c.name, c.footprint_ground + [5.0, 4.0], c.height_m) for c in CASTERS]
    rgb, ground, ground_from_px = _street(140.0, 45.0, moved)
    est = estimate_light(rgb, ground, np.zeros((H, W), bool), "labels", CASTERS, ground_from_px, 0.5, 0.6, PARAMS)
    assert est.method == "weak_fit" and est.fit_iou < PARAMS.min_fit_iou
    assert (est.sun_azimuth, est.sun_elevation) == (0.5, 0.6)


#: A building's footprint on the left of the street, its front wall 7 m from the road's axis.
BUILDING = np.array([[15.0, 7.0], [27.0, 7.0], [27.0, 19.0], [15.0, 19.0]])


@pytest.mark.parametrize(("azimuth", "elevation"), [(120.0, 52.0), (150.0, 60.0)])
def test_a_building_cut_by_the_image_top_pulls_no_sun_with_its_prior_height(
    azimuth: float, elevation: float
) -> None:
    # The photo shows a 10 m building's shadow; its top is out of view, so the world only
    # knows it stands at least 8 m high (what is seen) and at most the class's tallest.
    drawn = CASTERS + [ShadowCaster("building", BUILDING, 10.0)]
    rgb, ground, ground_from_px = _street(azimuth, elevation, drawn)
    sky = np.zeros((H, W), bool)

    def errors(building: ShadowCaster) -> tuple[float, float]:
        casters = CASTERS + [building]
        est = estimate_light(rgb, ground, sky, "labels", casters, ground_from_px, 0.5, 0.5, PARAMS)
        assert est.method == "cast_shadows"
        az = abs((math.degrees(est.sun_azimuth) - azimuth + 180.0) % 360.0 - 180.0)
        return az, abs(math.degrees(est.sun_elevation) - elevation)

    az, el = errors(ShadowCaster("building", BUILDING, 8.0, 24.0))
    assert az <= 5.0 and el <= 5.0
    # the old treatment: the prior's 25 m, whose long shadow into the lit street pulls the sun up
    az, el = errors(ShadowCaster("building", BUILDING, 25.0))
    assert el > 10.0


def test_a_caster_height_range_must_be_ordered() -> None:
    with pytest.raises(ValueError, match="height_max_m"):
        ShadowCaster("building", BUILDING, 8.0, 7.0)
    assert ShadowCaster("building", BUILDING, 8.0, 48.0).tallest_m == 48.0
    assert ShadowCaster("car", BUILDING, 1.5).tallest_m == 1.5


def test_shadowed_ground_hidden_in_the_unknown_band_earns_no_trust() -> None:
    # Two posts whose tops are out of view: the world knows them at least 1 m and at most
    # 12 m high, the photo shows the shadows of 8 m ones. Any sun along the shadows, low or
    # high, puts the dark ground between the 1 m and the 12 m shadows, where the fit claims
    # nothing: leaving that ground out, the overlap is 1 while its sure shadows cover a fifth of
    # the shadows and its elevation is anyone's guess. The gate reads the sure shadows.
    corners = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    posts = [ShadowCaster(f"post_{i}", corners + xy, 8.0) for i, xy in enumerate([(12.0, 6.0), (18.0, -6.5)])]
    rgb, ground, ground_from_px = _street(140.0, 45.0, posts)
    cut = [ShadowCaster(p.name, p.footprint_ground, 1.0, 12.0) for p in posts]
    est = estimate_light(rgb, ground, np.zeros((H, W), bool), "labels", cut, ground_from_px, 0.5, 0.6, PARAMS)
    assert est.fit_casters == 2  # both sure shadows meet shadowed ground: the caster gate passes
    assert (est.method, est.sun_azimuth, est.sun_elevation) == ("weak_fit", 0.5, 0.6)
    assert est.fit_iou < PARAMS.min_fit_iou
    # the same posts with their heights known: the fit explains the shadows and is trusted
    est = estimate_light(rgb, ground, np.zeros((H, W), bool), "labels", posts, ground_from_px, 0.5, 0.6, PARAMS)
    assert est.method == "cast_shadows" and est.fit_iou > 0.5
    assert abs((math.degrees(est.sun_azimuth) - 140.0 + 180.0) % 360.0 - 180.0) <= 5.0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(-5, 70000), min_size=1, max_size=200), st.integers(0, 1))
def test_present_ids_are_np_uniques_values(values: list[int], small: int) -> None:
    ids = np.array(values, dtype=np.int64) if not small else np.abs(np.array(values, dtype=np.int64)) % 7
    got = present_ids(ids.reshape(1, -1))
    assert got.tolist() == np.unique(ids).tolist()


@settings(max_examples=40, deadline=None)
@given(
    st.floats(0.0, 2 * math.pi),
    st.lists(st.floats(0.2, 1.5), min_size=1, max_size=6),
    st.integers(0, 2**31 - 1),
)
def test_one_entry_length_per_azimuth_is_the_swept_test_at_every_elevation(
    azimuth: float, elevations: list[float], seed: int
) -> None:
    # the shadow of each caster at each elevation, tested pair by pair with its own sweep vector
    rng = np.random.default_rng(seed)
    casters = [c for c in CASTERS if rng.random() < 0.7] or CASTERS[:1]
    points = rng.uniform([-5.0, -12.0], [35.0, 12.0], size=(400, 2))
    samples = _Samples(points, np.ones(len(points)), tuple(np.arange(len(points)) for _ in casters))
    pairs = _pairs(casters, samples)
    strip = _strip(pairs, azimuth)
    got = _strip_in_shadow(strip, elevations, PARAMS.reach_max_m, strip.height)
    away = -np.array([math.cos(azimuth), math.sin(azimuth)])
    rate = (pairs.normals @ away)[pairs.caster]
    for elevation, hits in zip(elevations, got, strict=True):
        length = np.minimum(pairs.height / math.tan(elevation), PARAMS.reach_max_m)
        expected = in_swept(pairs.slack, rate * length[:, None])
        # pairs within a micrometre of a swept outline may go either way
        near = (np.abs(pairs.slack) < 1e-6).any(axis=1)
        shadowed = np.zeros(len(pairs.sample), dtype=bool)
        shadowed[strip.pair[hits]] = True
        assert np.array_equal(shadowed[~near], expected[~near])


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 3), st.integers(1, 4))
def test_inner_ids_at_pixels_are_the_eroded_surfaces_there(seed: int, edge_px: int, surfaces: int) -> None:
    rng = np.random.default_rng(seed)
    ids = rng.integers(0, surfaces + 1, size=(6, 9))
    ids = np.kron(ids, np.ones((3, 2), dtype=np.int64))  # blocks, so some pixels survive the erosion
    v, u = np.nonzero(np.ones_like(ids, dtype=bool))
    assert np.array_equal(inner_ids_at(ids, v, u, edge_px), inner_ground(ids, edge_px)[v, u])


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 300), st.integers(0, 255), st.integers(1, 256))
def test_median_linear_is_np_median_of_the_decoded_pixels(seed: int, n: int, lo: int, span: int) -> None:
    pixels = np.random.default_rng(seed).integers(lo, min(lo + span, 256), size=(n, 3)).astype(np.uint8)
    assert np.array_equal(median_linear(pixels), np.median(uint8_to_linear(pixels), axis=0))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.01, 0.5), st.floats(0.05, 1.0))
def test_sky_colours_are_the_medians_of_the_first_and_last_pixels_in_row_order(
    seed: int, fraction: float, density: float
) -> None:
    rng = np.random.default_rng(seed)
    rgb = rng.integers(0, 256, size=(23, 17, 3)).astype(np.uint8)
    sky = rng.random((23, 17)) < density
    sky[rng.integers(0, 23), rng.integers(0, 17)] = True
    rows, cols = np.nonzero(sky)
    k = max(1, int(round(len(rows) * fraction)))
    zenith, horizon = sky_colours(rgb, sky, LightParams(sky_top_fraction=fraction))
    assert np.array_equal(zenith, np.median(uint8_to_linear(rgb[rows[:k], cols[:k]]), axis=0))
    assert np.array_equal(horizon, np.median(uint8_to_linear(rgb[rows[-k:], cols[-k:]]), axis=0))


def test_reference_stride_keeps_photos_up_to_the_reference_width_whole() -> None:
    widths = (640, 1024, 1242, 1600, 2047, 2048, 4000)
    assert [reference_stride(w, 1024) for w in widths] == [1, 1, 1, 1, 1, 2, 3]


def test_a_wide_photos_lit_references_are_measured_on_every_kth_row_and_column() -> None:
    # the drawn street at 2560 wide, the lit ground of its odd rows brighter: measured on
    # every 2nd row (reference_width_px 1024) the lit reference is the even rows' ground;
    # on every row (4096) the brighter rows hold its 75th percentile. The shadows are the
    # same in both, so the contrast tells the reference.
    rgb, ground, ground_from_px = _street(130.0, 40.0)
    wide, ids = (np.repeat(np.repeat(a, 4, axis=0), 4, axis=1) for a in (rgb, ground))
    lit_code, dark_code = int(rgb[ground > 0].max()), int(rgb[ground > 0].min())
    bright = int(np.round(linear_to_srgb(uint8_to_linear(np.uint8(lit_code)) * 1.3) * 255))
    odd_lit = (wide == lit_code) & (ids[:, :, None] > 0) & (np.arange(len(wide)) % 2 == 1)[:, None, None]
    wide[odd_lit] = bright
    wide_from_px = ground_from_px @ np.diag([0.25, 0.25, 1.0])
    lin = uint8_to_linear(np.array([lit_code, bright, dark_code], dtype=np.uint8))
    for width_px, lit in ((1024, lin[0]), (4096, lin[1])):
        params = LightParams(reference_width_px=width_px)
        sky = np.zeros(ids.shape, bool)
        est = estimate_light(wide, ids, sky, "labels", CASTERS, wide_from_px, 0.5, 0.6, params)
        assert est.shadow_contrast == pytest.approx(lit / lin[2], rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(0.0, 2 * math.pi), min_size=1, max_size=5),
    st.lists(st.floats(0.05, 1.5), min_size=1, max_size=8),
    st.integers(0, 2**31 - 1),
)
def test_all_azimuths_and_elevations_at_once_are_each_alone(
    azimuths: list[float], elevations: list[float], seed: int
) -> None:
    # the strips, the sure and unsure sets and their overlaps, as the fit found them one azimuth
    # and one elevation at a time; the poles' tops unseen (2 to 12 m): the unsure band
    rng = np.random.default_rng(seed)
    cut = [ShadowCaster(c.name, c.footprint_ground, 2.0, 12.0) for c in CASTERS if c.name.startswith("pole")]
    casters = [c for c in CASTERS + cut if rng.random() < 0.7] or cut
    points = rng.uniform([-5.0, -12.0], [35.0, 12.0], size=(400, 2))
    samples = _Samples(points, np.ones(len(points)), tuple(np.arange(len(points)) for _ in casters))
    pairs = _pairs(casters, samples)
    strips = _strips(pairs, azimuths)
    n = len(points)
    sure, unsure = _predicted_sets(strips, n, elevations, PARAMS.reach_max_m)
    observed = rng.random(n) < 0.3
    weight = rng.random(n)
    for a, azimuth in enumerate(azimuths):
        _one_azimuth(pairs, azimuth, strips[a], elevations, sure[a], unsure[a], observed, weight)


def _one_azimuth(
    pairs: _Pairs,
    azimuth: float,
    strip: _Strip,
    elevations: list[float],
    sure: np.ndarray,
    unsure: np.ndarray,
    observed: np.ndarray,
    weight: np.ndarray,
) -> None:
    """The batch's answers for one azimuth against that azimuth alone, elevation by elevation."""
    away = -np.array([math.cos(azimuth), math.sin(azimuth)])
    band = np.flatnonzero(
        (np.abs(pairs.offset @ np.array([-away[1], away[0]])) <= pairs.radius + 1e-9) & (pairs.offset @ away >= -pairs.radius - 1e-9)
    )
    assert np.array_equal(strip.pair, band)
    alone = sweep_entry(pairs.slack[band], (pairs.normals @ away)[pairs.caster[band]])
    assert np.array_equal(strip.entry, alone)  # bit for bit, inf where never
    n = len(observed)
    overlaps = _overlaps(sure, observed, weight, unsure)
    for e, elevation in enumerate(elevations):
        one_sure = np.zeros(n, dtype=bool)
        one_sure[strip.sample[_strip_in_shadow(strip, [elevation], PARAMS.reach_max_m, strip.height)[0]]] = True
        one_unsure = np.zeros(n, dtype=bool)
        hits = _strip_in_shadow(strip, [elevation], PARAMS.reach_max_m, strip.height_max, strip.unknown_top)[0]
        one_unsure[strip.sample[hits]] = True
        one_unsure &= ~one_sure
        assert np.array_equal(sure[e], one_sure) and np.array_equal(unsure[e], one_unsure)
        assert overlaps[e] == _overlap(one_sure, observed, weight, one_unsure)  # the same sums, bit for bit
