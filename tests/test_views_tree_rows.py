"""Two trees of a row that the drive's frames see apart are two trees, however near their triangulations."""

from __future__ import annotations

import numpy as np
from layout_support import ground_placement

from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.drive import _merge_estimate, _Track, cut_tail, seen_as_one_trunk
from usdworld.views.fusion import FusedObject, Observation, combine

PARAMS = ViewsParams()


def _item(frame: int, camera_x: float, xy: tuple[float, float], sigma_r: float, ref: int) -> FusedObject:
    """One frame's tree (2.6 m square footprint) placed at ``xy`` by a camera at (camera_x, 0)."""
    camera = np.array([camera_x, 0.0])
    cue = DepthCue("contact", float(np.linalg.norm(np.asarray(xy) - camera)), sigma_r)
    placement = ground_placement("tree", xy, (100, 40, 104, 160), (2.6, 2.6, 6.0), cues=(cue,), ref=ref)
    o = Observation(frame, f"f{frame}", f"f{frame}.png", placement, camera, sigma_r, 0.3)
    _, cov = combine([o])
    return FusedObject(placement, (o,), "single", cov)


def _track(frames: list[int], xy: tuple[float, float], ref: int, sigma_r: float = 10.0) -> _Track:
    """A standing tree's track: the frames (camera 1 m on per frame) that place it at ``xy``."""
    tr = _Track("tree", 0.0, [0.1 * k for k in frames], [_item(k, 1.0 * k, xy, sigma_r, ref) for k in frames])
    tr.refit()
    return tr


def _one(a: _Track, b: _Track) -> bool:
    return seen_as_one_trunk(a, b, _merge_estimate(a, PARAMS), _merge_estimate(b, PARAMS), PARAMS)


def test_two_trees_of_a_row_seen_apart_in_every_frame_stay_two() -> None:
    """Two trees 8 m apart in a row 4 m beside a drive that ends 90 m short of them: from there they
    overlap across every viewing ray (0.3 m apart across it, the footprints reach 2.6 m) and their
    depths (10 m spread) cannot tell them apart, but all ten frames see them as two objects: a view
    cuts one crown in two only in the frames where something stands in front of it."""
    a = _track(list(range(10)), (100.0, -4.0), 1)
    b = _track(list(range(10)), (108.0, -4.0), 2)
    assert not _one(a, b)
    assert not _one(b, a)


def test_a_crown_cut_in_two_in_a_few_frames_is_one_tree() -> None:
    """A tree's second track holds four frames, of which two also hold the first track's observation
    (its crown cut in two there): one tree."""
    a = _track(list(range(10)), (60.0, -4.0), 1, sigma_r=3.0)
    b = _track([8, 9, 10, 11], (61.0, -4.0), 2, sigma_r=3.0)
    assert _one(a, b)
    assert _one(b, a)


def test_a_second_track_is_two_trees_only_when_too_many_of_its_frames_are_shared() -> None:
    """A twelve-frame second track: ten shared frames are a crown cut in half the frames or fewer by
    chance 1.9 % of the time (one tree, above the gate's 1 %), eleven 0.32 % (two trees)."""
    a = _track(list(range(20)), (60.0, -4.0), 1, sigma_r=3.0)
    assert _one(a, _track(list(range(10, 22)), (61.0, -4.0), 2, sigma_r=3.0))
    assert not _one(a, _track(list(range(9, 21)), (61.0, -4.0), 2, sigma_r=3.0))


def test_cut_tail_is_the_binomial_tail_at_one_half() -> None:
    """Known answers, and the tail falls as more frames are shared."""
    assert cut_tail(0, 7) == 1.0
    assert cut_tail(3, 3) == 0.125
    assert cut_tail(10, 12) == 79 / 4096
    assert all(cut_tail(k + 1, 20) < cut_tail(k, 20) for k in range(20))


def _track_with(frames: list[int], xy: tuple[float, float], ref: int, other: dict[int, tuple[float, float]]) -> _Track:
    """As :func:`_track`, but the frames in ``other`` hold what the view saw at another point."""
    items = [_item(k, 1.0 * k, other.get(k, xy), 3.0, ref) for k in frames]
    tr = _Track("tree", 0.0, [0.1 * k for k in frames], items)
    tr.refit()
    return tr


def test_a_shared_frame_of_another_tree_does_not_keep_a_crown_cut_in_two_apart() -> None:
    """A tree's second track (its crown cut in two in frames 8 and 9) also holds, in frame 9, a far
    neighbour's observation 15 m on and 5 m aside, whose ray misses the track's footprint by 3 m: that
    frame says nothing about whether the two tracks are one tree, so they are one. Where the second
    track's own frame 9 is the crown's half, it is one tree as well; and two trees seen apart in
    every frame stay two."""
    a = _track(list(range(10)), (60.0, -4.0), 1, sigma_r=3.0)
    b = _track_with([8, 9, 10, 11], (61.0, -4.0), 2, {9: (75.0, -9.0)})
    assert _one(a, b)
    assert _one(b, a)
    assert _one(a, _track_with([8, 9, 10, 11], (61.0, -4.0), 2, {}))
    assert not _one(_track(list(range(10)), (100.0, -4.0), 1), _track(list(range(10)), (108.0, -4.0), 2))
