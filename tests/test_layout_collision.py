"""AABB collision resolution: known answer, the properties of the issue, and the brute-force reference."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from usdworld.layout import collision
from usdworld.layout.collision import TOLERANCE_M, footprint_half_extents, overlaps, resolve_collisions
from usdworld.parameters.collision import CollisionParams


def test_two_boxes_known_answer():
    centers = np.array([[0.0, 0.0], [1.0, 0.2]])
    half = np.array([[1.0, 0.5], [1.0, 0.5]])
    result = resolve_collisions(centers, half, priority=np.array([0.0, 1.0]))
    # The first stays; the second moves the shortest way out: along y by 0.8 m (+clearance).
    np.testing.assert_allclose(result.displacement[0], [0.0, 0.0])
    assert abs(result.displacement[1, 0]) < 1e-12
    assert 0.8 <= result.displacement[1, 1] <= 0.8 + TOLERANCE_M


def test_footprint_half_extents_rotated():
    half = footprint_half_extents(np.array([[4.0, 2.0], [4.0, 2.0]]), np.array([0.0, np.pi / 2]))
    np.testing.assert_allclose(half, [[2.0, 1.0], [1.0, 2.0]], atol=1e-12)


boxes = st.integers(1, 25).flatmap(
    lambda n: st.tuples(
        st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20)), min_size=n, max_size=n),
        st.lists(st.tuples(st.floats(0.2, 3), st.floats(0.2, 3)), min_size=n, max_size=n),
        st.lists(st.floats(0, 100), min_size=n, max_size=n),
        st.randoms(use_true_random=False),
    )
)


@given(boxes)
def test_no_overlap_idempotent_order_independent(data):
    centers, half, priority, rnd = (np.array(data[0]), np.array(data[1]), np.array(data[2]), data[3])
    result = resolve_collisions(centers, half, priority)
    assert overlaps(result.centers, half) == []
    again = resolve_collisions(result.centers, half, priority)
    np.testing.assert_allclose(again.displacement, 0.0)
    perm = np.array(rnd.sample(range(len(centers)), len(centers)))
    shuffled = resolve_collisions(centers[perm], half[perm], priority[perm])

    def rows(c, h, p, out):  # input -> output pairs as a sorted table (identical inputs are interchangeable)
        table = np.column_stack([c, h, p, out])
        return table[np.lexsort(table.T[::-1])]

    np.testing.assert_allclose(
        rows(centers[perm], half[perm], priority[perm], shuffled.centers), rows(centers, half, priority, result.centers)
    )


@given(boxes)
def test_separated_boxes_do_not_move(data):
    centers = np.array([[10.0 * i, 0.0] for i in range(len(data[0]))])
    half = np.array(data[1])
    result = resolve_collisions(centers, half, np.array(data[2]))
    np.testing.assert_allclose(result.displacement, 0.0)


# --- brute-force reference: every pair tested, every candidate sorted (the algorithm before the index) ---


def _reference(centers, half, priority, tol=TOLERANCE_M, clearance=0.005, reach=50.0, max_m=25.0):
    """Centres after resolution and which boxes were placed: candidates beyond ``max_m`` are
    never taken, and a box with no free candidate within it is not placed."""
    def clear(cand, h, pc, ph):
        if len(pc) == 0:
            return np.ones(len(cand), dtype=bool)
        gap = np.abs(cand[:, None, :] - pc[None, :, :]) - (h[None, None, :] + ph[None, :, :])
        return ~np.any(np.all(gap < -tol, axis=2), axis=1)

    def candidates(c0, h, pc, ph):
        xs = np.concatenate([[c0[0]], pc[:, 0] - ph[:, 0] - h[0] - clearance, pc[:, 0] + ph[:, 0] + h[0] + clearance])
        ys = np.concatenate([[c0[1]], pc[:, 1] - ph[:, 1] - h[1] - clearance, pc[:, 1] + ph[:, 1] + h[1] + clearance])
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        return np.column_stack([X.ravel(), Y.ravel()])

    def nearest_clear(c0, cand, h, pc, ph):
        dist = np.linalg.norm(cand - c0, axis=1)
        order = np.lexsort((cand[:, 1], cand[:, 0], dist))
        order = order[dist[order] <= max_m]
        ok = np.nonzero(clear(cand[order], h, pc, ph))[0]
        return cand[order[ok[0]]] if len(ok) else None

    order = np.lexsort((half[:, 1], half[:, 0], centers[:, 1], centers[:, 0], priority))
    out = centers.copy()
    kept = np.ones(len(centers), dtype=bool)
    placed: list[int] = []
    for i in order:
        c0, h = centers[i], half[i]
        pc, ph = out[placed], half[placed]
        if clear(c0[None, :], h, pc, ph)[0]:
            placed.append(int(i))
            continue
        near = np.all(np.abs(pc - c0) < ph + h + reach, axis=1)
        best = nearest_clear(c0, candidates(c0, h, pc[near], ph[near]), h, pc, ph)
        if best is None and max_m > reach:
            best = nearest_clear(c0, candidates(c0, h, pc, ph), h, pc, ph)
        if best is None:
            kept[i] = False
            continue
        out[i] = best
        placed.append(int(i))
    return out, kept


# Scenes with many ties and repeats: coordinates on a coarse lattice, a few sizes, whole-metre
# priorities, boxes far apart (beyond the 50 m neighbourhood), -0.0 next to 0.0.
lattice = st.sampled_from([-60.0, -2.0, -1.0, -0.5, -0.0, 0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 70.0])
dense = st.integers(1, 40).flatmap(
    lambda n: st.tuples(
        st.lists(st.tuples(st.one_of(lattice, st.floats(-8, 8)), st.one_of(lattice, st.floats(-8, 8))), min_size=n, max_size=n),
        st.lists(st.tuples(st.sampled_from([0.5, 1.0, 2.25]), st.sampled_from([0.5, 1.0, 2.25])), min_size=n, max_size=n),
        st.lists(st.sampled_from([0.0, 1.0, 2.0]), min_size=n, max_size=n),
    )
)


@settings(max_examples=200, deadline=None)
@given(st.one_of(boxes.map(lambda d: d[:3]), dense))
def test_indexed_equals_brute_force_reference(data):
    centers, half, priority = (np.array(d, dtype=np.float64).reshape(len(data[0]), -1) for d in data)
    priority = priority.ravel()
    result = resolve_collisions(centers, half, priority, UNCAPPED)
    expected, kept = _reference(centers, half, priority)
    assert result.centers.tobytes() == expected.tobytes()  # bit for bit, signs of zero included
    np.testing.assert_array_equal(result.placed, kept)
    # the default candidate cap never binds on these small scenes either
    assert resolve_collisions(centers, half, priority).centers.tobytes() == expected.tobytes()


@settings(max_examples=50, deadline=None)
@given(st.integers(2, 60), st.sampled_from([0.5, 2.0, 5.0]))
def test_pile_reference_with_small_max_displacement(n, max_m):
    # Identical boxes on one spot with a small displacement bound: the reference and the
    # index agree on which are dropped and where the rest go.
    centers, half, priority = np.zeros((n, 2)), np.tile([1.0, 0.5], (n, 1)), np.arange(n, dtype=np.float64)
    params = CollisionParams(max_displacement_m=max_m, max_candidates=10**9)
    result = resolve_collisions(centers, half, priority, params)
    expected, kept = _reference(centers, half, priority, max_m=max_m)
    assert result.centers.tobytes() == expected.tobytes()
    np.testing.assert_array_equal(result.placed, kept)


#: No cap on the candidates tested: the reference sorts every candidate.
UNCAPPED = CollisionParams(max_candidates=10**9)


def test_params_change_the_tolerance():
    centers = np.array([[0.0, 0.0], [1.95, 0.0]])  # overlap of 0.05 m along x
    half = np.array([[1.0, 1.0], [1.0, 1.0]])
    assert np.any(resolve_collisions(centers, half, np.array([0.0, 1.0])).displacement)
    loose = resolve_collisions(centers, half, np.array([0.0, 1.0]), CollisionParams(tolerance_m=0.1))
    np.testing.assert_array_equal(loose.displacement, 0.0)


def _car_park(n, seed=0):
    """A car park of n cars in rows (7 m x 3 m bays), each jittered by up to 1.5 m: neighbours overlap."""
    rng = np.random.default_rng(seed)
    cols = int(np.ceil(np.sqrt(n)))
    bays = np.array([[7.0 * (k % cols), 3.0 * (k // cols)] for k in range(n)])
    half = np.tile([2.25, 0.9], (n, 1))
    return bays + rng.uniform(-1.5, 1.5, size=(n, 2)), half, rng.uniform(0, 50, n)


def test_dense_scene_work_is_near_linear():
    # 1,000 jittered cars, hundreds of overlapping pairs: every box is tested against a
    # handful of neighbours, not against all settled ones (testing every settled box
    # makes ~N^2/2 = 5e5 tests for the first check alone).
    centers, half, priority = _car_park(1000)
    assert len(overlaps(centers, half)) > 100
    result = resolve_collisions(centers, half, priority)
    assert overlaps(result.centers, half) == []
    small = resolve_collisions(*_car_park(250))
    assert result.pair_checks < 200 * 1000  # measured: about 1e5
    assert result.pair_checks < 10 * small.pair_checks  # 4x the boxes, not 16x the work (measured: 7x)


def _identical_pile(n):
    """n identical car footprints (4.5 m x 1.8 m) on one spot, equal priorities."""
    return np.zeros((n, 2)), np.tile([2.25, 0.9], (n, 1)), np.zeros(n)


def test_pile_of_identical_boxes_is_bounded_and_drops_the_excess():
    # 300 identical footprints: a 25 m disk holds ~240 cars, so the rest cannot be placed.
    # Unbounded, every box searched every spot flush against those settled so far: the
    # pair checks grew as N^3 (measured 3.4e8 for 300; the 150 boxes took 12 s).
    centers, half, priority = _identical_pile(300)
    params = CollisionParams()
    result = resolve_collisions(centers, half, priority, params)
    placed = result.placed
    assert 50 < placed.sum() < 300  # the excess is dropped, a crowd remains
    np.testing.assert_array_equal(result.displacement[~placed], 0.0)
    np.testing.assert_array_equal(result.centers[~placed], centers[~placed])
    assert np.all(np.linalg.norm(result.displacement[placed], axis=1) <= params.max_displacement_m)
    assert overlaps(result.centers[placed], half[placed]) == []
    # bounded work: at most max_candidates spots per box, each against the boxes near them
    assert result.pair_checks < 300 * params.max_candidates * 64
    big = resolve_collisions(*_identical_pile(600), params)
    assert big.placed.sum() == placed.sum()  # the disk is full: the extra 300 are all dropped
    assert big.pair_checks < 4 * result.pair_checks  # 2x the boxes, not 8x the work (measured 2.9x)


def test_pile_of_random_boxes_properties_hold_for_what_is_placed():
    # Random boxes heaped on a 10 m square: dropped ones excepted, no overlap, idempotent
    # (the placed boxes resolved again move nowhere and all stay), independent of input order.
    rng = np.random.default_rng(3)
    n = 400
    centers = rng.uniform(-5, 5, (n, 2))
    half = footprint_half_extents(np.column_stack([rng.uniform(3.5, 5, n), rng.uniform(1.6, 2, n)]), rng.uniform(0, np.pi, n))
    priority = rng.uniform(0, 50, n)
    assert len(overlaps(centers, half)) > 10 * n
    result = resolve_collisions(centers, half, priority)
    p = result.placed
    assert 0 < p.sum() < n
    assert overlaps(result.centers[p], half[p]) == []
    again = resolve_collisions(result.centers[p], half[p], priority[p])
    assert again.placed.all()
    np.testing.assert_array_equal(again.displacement, 0.0)
    perm = rng.permutation(n)
    shuffled = resolve_collisions(centers[perm], half[perm], priority[perm])
    assert shuffled.centers.tobytes() == result.centers[perm].tobytes()
    np.testing.assert_array_equal(shuffled.placed, p[perm])


def test_max_candidates_drops_what_it_cannot_reach():
    # A car on one spot, then copies. The second's ring of radius 2 m holds 1 x 3 spots (the
    # spot itself, flush below and above the first); the third's holds 1 x 4 (flush above the
    # second, at 0.0 + rounding, is a fourth y). A cap of 1 places only the first, 3 the first
    # two, 4 the first three; the rest are dropped, and what is placed does not overlap.
    centers, half, priority = _identical_pile(20)
    for cap, expected in ((1, 1), (3, 2), (4, 3)):
        result = resolve_collisions(centers, half, priority, CollisionParams(max_candidates=cap))
        assert result.placed.sum() == expected
        assert overlaps(result.centers[result.placed], half[result.placed]) == []


@settings(max_examples=40, deadline=None)
@given(
    st.integers(20, 120),
    st.sampled_from([2.0, 6.0, 25.0]),
    st.sampled_from([3.0, 8.0]),
    st.sampled_from([200, 4096, 65536]),
    st.integers(0, 2**31 - 1),
)
def test_pile_shortcut_changes_no_result(n, side, max_m, cap, seed):
    # The raster that proves a disk blocked (usdworld.layout.occupancy) only skips rings
    # with no free spot: with it and without it, the same boxes land on the same bits.
    rng = np.random.default_rng(seed)
    centers = rng.uniform(-side, side, (n, 2))
    half = footprint_half_extents(np.column_stack([rng.uniform(3.5, 5, n), rng.uniform(1.6, 2, n)]), rng.uniform(0, np.pi, n))
    priority = rng.uniform(0, 50, n)
    params = CollisionParams(max_displacement_m=max_m, max_candidates=cap)
    fast = resolve_collisions(centers, half, priority, params)
    original = collision.blocked_radius
    collision.blocked_radius = lambda *args: -np.inf
    try:
        exact = resolve_collisions(centers, half, priority, params)
    finally:
        collision.blocked_radius = original
    assert fast.centers.tobytes() == exact.centers.tobytes()
    np.testing.assert_array_equal(fast.placed, exact.placed)
    assert fast.pair_checks <= exact.pair_checks


def test_pile_shortcut_drops_a_full_disk_cheaply():
    # 600 identical cars on one spot: once the disk is full, each further car is refused by
    # the raster, not by searching every ring (the exact search made 2.9x the checks of 300).
    small, big = resolve_collisions(*_identical_pile(300)), resolve_collisions(*_identical_pile(600))
    assert big.placed.sum() == small.placed.sum()
    assert big.pair_checks < 1.2 * small.pair_checks


def test_degenerate_bounds_place_only_the_first_of_a_pile():
    # A bound of zero, below zero or NaN (a hand-edited parameters file) finds no spot to
    # move to: the first box stays, the rest are dropped, as the exact rings decide.
    centers, half, priority = _identical_pile(5)
    for bound in (-1.0, 0.0, float("nan")):
        result = resolve_collisions(centers, half, priority, CollisionParams(max_displacement_m=bound))
        np.testing.assert_array_equal(result.placed, [True, False, False, False, False])
        np.testing.assert_array_equal(result.displacement, 0.0)


def _region(depth):
    """An :class:`Admissible` for a camera at the origin looking along +x (depth = x)."""
    return collision.Admissible(
        eye=np.zeros(2), depth_axis=np.array([1.0, 0.0]), depth_offset=0.0, depth=np.asarray(depth, dtype=np.float64)
    )


def _wall_in_front_of_a_row():
    # A row of cars seen as one 2 x 40 m box (settles first) at 10 m; a wall piece drafted
    # over it, 12 m deep across the view (half extents 1 x 6). Sideways it would move 25.5 m
    # (past the search's 25 m); its nearest free spot is 2 m towards the camera (x 7.995),
    # where it would stand across the road in front of the cars.
    centers = np.array([[10.0, 0.0], [10.0, 0.5]])
    half = np.array([[1.0, 20.0], [1.0, 6.0]])
    return centers, half, np.array([0.0, 1.0])


def test_a_box_is_not_pushed_where_the_photo_contradicts_it():
    centers, half, priority = _wall_in_front_of_a_row()
    free = resolve_collisions(centers, half, priority)  # without the photo's bounds: 2 m towards the camera
    assert free.placed.all() and free.centers[1, 0] == 10.0 - 2.0 - 0.005
    # its cues allow 9 to 11 m: neither 2 m nearer nor behind the car (x >= 12.005)
    res = resolve_collisions(centers, half, priority, admissible=_region([[9.0, 11.0], [9.0, 11.0]]))
    assert res.placed.tolist() == [True, False] and res.contradicted.tolist() == [False, True]
    assert np.array_equal(res.centers, centers)


def test_a_box_moves_back_behind_what_it_hit_when_its_depth_range_allows():
    centers, half, priority = _wall_in_front_of_a_row()
    region = _region([[9.0, 11.0], [9.0, 14.0]])
    res = resolve_collisions(centers, half, priority, admissible=region)
    assert res.placed.all() and not res.contradicted.any()
    # just behind the cars (x 12.005)
    np.testing.assert_allclose(res.centers[1], [12.005, 0.5], atol=1e-9)
    assert overlaps(res.centers, half) == []


def test_along_the_ray_the_nearest_free_spot_is_an_end_of_a_blocked_interval():
    # One settled 2 x 2 box at (10, 0); a 2 x 2 box drafted on it, seen along the ray of
    # bearing 0, is free 2.005 m before or behind it: the tie goes to the smaller t (in
    # front) where its depth range allows, else behind; neither within 9 to 11 m.
    centers = np.array([[10.0, 0.0]])
    half = np.array([[1.0, 1.0]])
    settled = collision._Settled(centers.copy(), half, TOLERANCE_M)
    settled.add(0)
    search = collision._Search(0.005, 25.0, 65536)
    h = np.array([1.0, 1.0])
    region = _region([[9.0, 13.0]])
    spot = collision._along_ray(np.array([10.0, 0.0]), h, settled, search, region, 0)
    np.testing.assert_allclose(spot, [12.005, 0.0])
    region = _region([[5.0, 13.0]])
    spot = collision._along_ray(np.array([10.0, 0.0]), h, settled, search, region, 0)
    np.testing.assert_allclose(spot, [7.995, 0.0])
    region = _region([[9.0, 11.0]])
    assert collision._along_ray(np.array([10.0, 0.0]), h, settled, search, region, 0) is None


def test_an_allowed_nearest_spot_is_the_unconstrained_answer():
    centers, half, priority = _wall_in_front_of_a_row()
    wide = _region([[-np.inf, np.inf]] * 2)
    a = resolve_collisions(centers, half, priority)
    b = resolve_collisions(centers, half, priority, admissible=wide)
    assert np.array_equal(a.centers, b.centers) and not b.contradicted.any()


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_admissible_resolution_leaves_no_overlap_and_keeps_each_box_in_its_depths(data):
    n = data.draw(st.integers(2, 12))
    xy = data.draw(st.lists(st.tuples(st.floats(5, 30), st.floats(-8, 8)), min_size=n, max_size=n))
    hw = data.draw(st.lists(st.tuples(st.floats(0.2, 3), st.floats(0.2, 3)), min_size=n, max_size=n))
    centers, half = np.array(xy), np.array(hw)
    region = _region(np.column_stack([centers[:, 0] - 3, centers[:, 0] + 3]))
    res = resolve_collisions(centers, half, np.arange(n, dtype=np.float64), admissible=region)
    kept = np.nonzero(res.placed)[0]
    assert overlaps(res.centers[kept], half[kept]) == []
    for i in kept:
        assert region.allows(int(i), res.centers[i, :1], res.centers[i, 1:])[0, 0]
    assert not (res.contradicted & res.placed).any()
