"""AABB collision resolution: known answer, the properties of the issue, and the brute-force reference."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

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


def _reference(centers, half, priority, tol=TOLERANCE_M, clearance=0.005, reach=50.0):
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
        order = np.lexsort((cand[:, 1], cand[:, 0], np.linalg.norm(cand - c0, axis=1)))
        ok = np.nonzero(clear(cand[order], h, pc, ph))[0]
        return cand[order[ok[0]]] if len(ok) else None

    order = np.lexsort((half[:, 1], half[:, 0], centers[:, 1], centers[:, 0], priority))
    out = centers.copy()
    placed: list[int] = []
    for i in order:
        c0, h = centers[i], half[i]
        pc, ph = out[placed], half[placed]
        if clear(c0[None, :], h, pc, ph)[0]:
            placed.append(int(i))
            continue
        near = np.all(np.abs(pc - c0) < ph + h + reach, axis=1)
        best = nearest_clear(c0, candidates(c0, h, pc[near], ph[near]), h, pc, ph)
        if best is None:
            best = nearest_clear(c0, candidates(c0, h, pc, ph), h, pc, ph)
        out[i] = best
        placed.append(int(i))
    return out


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
    result = resolve_collisions(centers, half, priority)
    expected = _reference(centers, half, priority)
    assert result.centers.tobytes() == expected.tobytes()  # bit for bit, signs of zero included


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
