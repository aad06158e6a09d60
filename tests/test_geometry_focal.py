"""Known-answer tests of the focal-length cues and their fusion (synthetic cameras, hand-made boxes)."""

from __future__ import annotations

import numpy as np
import pytest

from usdworld.errors import CalibrationError
from usdworld.geometry.focal import (
    BoxShapes,
    FocalCue,
    box_shape_cue,
    focal_from_orthogonal_vps,
    fuse_focal,
    principal_point,
    prior_cue,
)
from usdworld.geometry.vanishing import (
    VanishingPoint,
    find_vertical_vanishing_point,
    principal_point_f2_sigma,
    vanishing_focal_cue,
)
from usdworld.parameters.camera import CameraParams

W, H = 1242, 375


def _rotation(pitch: float, yaw: float) -> np.ndarray:
    """cam_from_world-like rotation: yaw about the vertical (y), then pitch about x (down positive)."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    r_yaw = np.array([[cy, 0, -sy], [0, 1, 0], [sy, 0, cy]])
    r_pitch = np.array([[1, 0, 0], [0, cp, sp], [0, -sp, cp]])
    return r_pitch @ r_yaw


def _project(points: np.ndarray, f: float, R: np.ndarray, w: int, h: int) -> np.ndarray:
    p = points @ R.T
    c = principal_point(w, h)
    return np.column_stack([c[0] + f * p[:, 0] / p[:, 2], c[1] + f * p[:, 1] / p[:, 2]])


def test_orthogonal_vanishing_points_known_answer():
    f, c = 800.0, np.array([500.0, 300.0])
    # directions (1, 0, 1) and (-1, 0, 1) are orthogonal: vps at c +- (f, 0)
    assert focal_from_orthogonal_vps(c + [f, 0], c - [f, 0], c) == pytest.approx(f)
    assert focal_from_orthogonal_vps(c + [f, 0], c + [f, 0], c) is None


def test_street_and_vertical_lines_give_f_back():
    """A pitched camera (8 deg) looking along a street: the kerb-like lines and the poles give f within 5 %."""
    f_true, w, h = 900.0, 1280, 720
    street, segments = _street_and_poles(8.0, f_true, w, h)
    assert find_vertical_vanishing_point(segments, w, h) is not None
    cue = vanishing_focal_cue(street, find_vertical_vanishing_point(segments, w, h), w, h, CameraParams())
    assert cue is not None and cue.source == "vanishing_points"
    assert cue.f_px == pytest.approx(f_true, rel=0.05)
    assert cue.sigma_log < 0.5


def _street_and_poles(pitch_deg: float, f_true: float = 900.0, w: int = 1280, h: int = 720):
    """Kerb-like lines along a street and poles seen by a camera pitched down ``pitch_deg``, yawed 5 deg."""
    R = _rotation(np.radians(pitch_deg), np.radians(5.0))
    segments = []
    for x in (-6.0, -3.0, 3.0, 6.0, -9.0, 9.0):
        for y in (1.5, -2.0):
            a, b = _project(np.array([[x, y, 8.0], [x, y, 30.0]]), f_true, R, w, h)
            segments.append([*a, *b])
    for x, z in [(-5, 10), (5, 12), (-7, 20), (7, 25), (-4, 15), (4, 18), (-8, 30), (8, 35), (-6, 40), (6, 45)]:
        a, b = _project(np.array([[x, 1.5, z], [x, -4.0, z]]), f_true, R, w, h)
        segments.append([*a, *b])
    street_dir = R @ np.array([0.0, 0.0, 1.0])
    vp = principal_point(w, h) + f_true * street_dir[:2] / street_dir[2]
    return VanishingPoint(float(vp[0]), float(vp[1]), 0.5, 12, 12), np.array(segments)


def test_principal_point_spread_of_f2_known_answer():
    """The gradient of f^2 in c is (v1 - c) + (v2 - c): its norm times the spread per axis."""
    c, diag = np.array([600.0, 200.0]), 1000.0
    p = CameraParams(principal_point_sigma_fraction=0.01)
    got = principal_point_f2_sigma(c + [30.0, 0.0], c + [0.0, -40.0], c, diag, p)
    assert got == pytest.approx(50.0 * 10.0)
    # symmetric in the two points, and zero for points symmetric about the centre
    assert principal_point_f2_sigma(c + [0.0, -40.0], c + [30.0, 0.0], c, diag, p) == pytest.approx(got)
    assert principal_point_f2_sigma(c + [300.0, 0.0], c - [300.0, 0.0], c, diag, p) == pytest.approx(0.0)


def test_a_nearly_level_camera_makes_the_vanishing_point_cue_weak():
    """f comes back exactly at any pitch, but the unknown principal point (1.4 % of the
    diagonal) moves f^2 by the far vertical point's lever arm: at 1 deg of pitch the cue is
    weaker than the prior (0.3), at 8 deg it is a measurement (and the spread falls with pitch)."""
    sigmas = []
    for pitch in (1.0, 3.0, 8.0):
        street, segments = _street_and_poles(pitch)
        vertical = find_vertical_vanishing_point(segments, 1280, 720)
        cue = vanishing_focal_cue(street, vertical, 1280, 720, CameraParams())
        assert cue is not None and cue.f_px == pytest.approx(900.0, rel=1e-6)
        sigmas.append(cue.sigma_log)
    assert sigmas[0] > 0.6 and sigmas[2] < 0.15
    assert sigmas == sorted(sigmas, reverse=True)


def _kitti_boxes(f: float, cam_h: float, placements, size=(4.2, 1.8, 1.5)) -> BoxShapes:
    c = principal_point(W, H)
    boxes = []
    L, Wd, Hh = size
    for X, Z in placements:
        pts = np.array([(X + dx, y, Z + dz) for dx in (-Wd / 2, Wd / 2) for dz in (-L / 2, L / 2) for y in (cam_h, cam_h - Hh)])
        u, v = c[0] + f * pts[:, 0] / pts[:, 2], c[1] + f * pts[:, 1] / pts[:, 2]
        boxes.append([u.min(), v.min(), u.max(), v.max()])
    n = len(boxes)
    return BoxShapes(np.array(boxes), np.tile(size, (n, 1)).astype(float), np.full(n, 0.12))


def test_box_shapes_give_f_back():
    """Street-aligned cars of the class size seen by a level camera give f back within two of their own sigmas.

    The box shapes measure f times the camera height far better than either (the side a
    car shows spans ~ L (u - c_x) / (f h) pixels), so the camera-height prior (1.5 +- 0.3 m)
    leaves an honest spread of 20-40 %: the test holds the cue to the spread it states.
    """
    for f_true, h_true in ((721.0, 1.65), (450.0, 1.5), (1100.0, 1.3)):
        shapes = _kitti_boxes(f_true, h_true, [(-4, 12), (3.5, 15), (-3, 25), (6, 20), (0.5, 30), (-7, 18)])
        cue = box_shape_cue(W, H, shapes, params=CameraParams())
        assert cue is not None
        assert cue.sigma_log < 0.5
        assert abs(np.log(cue.f_px / f_true)) < 2 * cue.sigma_log


def test_box_shapes_with_the_true_camera_height_are_tight():
    """With the height prior narrowed to the truth, the same boxes give f within 3 %."""
    params = CameraParams(height_prior_mean_m=1.65, height_prior_std_m=0.02)
    shapes = _kitti_boxes(721.0, 1.65, [(-4, 12), (3.5, 15), (-3, 25), (6, 20), (0.5, 30), (-7, 18)])
    cue = box_shape_cue(W, H, shapes, params=params)
    assert cue is not None and cue.f_px == pytest.approx(721.0, rel=0.03)


def test_published_car_proportions_bracket_the_focal_length():
    """Cars shaped as KITTI's mean (3.88 x 1.63 x 1.53 m) and as nuScenes' (4.61 x 1.95 x 1.72 m)
    fall either side of the true f when the cue assumes their geometric mean
    (``shape_car_size_m``), each within its stated spread; the class table's flatter car
    (4.2 x 1.8 x 1.5 m) reads both long, KITTI's by more than 30 %."""
    p = CameraParams()
    place = [(-4, 12), (3.5, 15), (-3, 25), (6, 20), (0.5, 30), (-7, 18)]
    for f_true, h_true in ((721.0, 1.65), (1100.0, 1.3)):
        ratios = {}
        for name, size in (("kitti", (3.88, 1.63, 1.53)), ("nuscenes", (4.61, 1.95, 1.72))):
            seen = _kitti_boxes(f_true, h_true, place, size=size)
            for assumed in ("published", "table"):
                car = p.shape_car_size_m if assumed == "published" else (4.2, 1.8, 1.5)
                shapes = BoxShapes(seen.box_px, np.tile(car, (len(seen), 1)), seen.height_std_m)
                cue = box_shape_cue(W, H, shapes, params=p)
                assert cue is not None
                ratios[name, assumed] = cue.f_px / f_true
                if assumed == "published":
                    assert abs(np.log(ratios[name, assumed])) < cue.sigma_log
        assert ratios["kitti", "published"] > 1.0 > ratios["nuscenes", "published"]
        assert ratios["kitti", "table"] > 1.3 and ratios["nuscenes", "table"] > 1.1


def test_box_shapes_need_two_vehicles():
    assert box_shape_cue(W, H, _kitti_boxes(721.0, 1.65, [(-4, 12)])) is None


def test_fusion_is_inverse_variance_in_log_f():
    a, b = FocalCue("exif", 1000.0, 0.1, "a"), FocalCue("box_shapes", 1100.0, 0.2, "b")
    est = fuse_focal([a, b])
    w = np.array([100.0, 25.0])
    assert est.f_px == pytest.approx(np.exp((w @ np.log([1000.0, 1100.0])) / w.sum()))
    assert est.sigma_log == pytest.approx(1 / np.sqrt(125.0))
    assert est.dropped == ()


def test_a_wrong_cue_is_dropped():
    prior = prior_cue(W, H)
    good = [FocalCue("exif", 720.0, 0.03, "tag"), FocalCue("box_shapes", 740.0, 0.1, "cars")]
    wrong = FocalCue("vanishing_points", 2000.0, 0.1, "a fence")
    est = fuse_focal([prior, *good, wrong])
    assert [c.source for c in est.dropped] == ["vanishing_points"]
    assert est.f_px == pytest.approx(722.0, rel=0.02)
    assert "dropped as inconsistent: vanishing_points" in est.describe()


def test_two_disagreeing_cues_keep_the_surer():
    est = fuse_focal([FocalCue("prior", 800.0, 0.3, "p"), FocalCue("exif", 250.0, 0.03, "fisheye")])
    assert est.sources == ("exif",) and est.f_px == pytest.approx(250.0)


def test_cue_validation():
    with pytest.raises(CalibrationError, match="sigma_log"):
        FocalCue("exif", 700.0, 0.0, "x")
    with pytest.raises(CalibrationError, match="no cues"):
        fuse_focal([])


def test_prior_is_the_documented_fraction_of_the_diagonal():
    p = CameraParams()
    assert prior_cue(W, H, p).f_px == pytest.approx(p.focal_prior_diag_ratio * np.hypot(W, H))


def _profile_cue(m: float, likelihood, lo: float = -3.0, hi: float = 3.0, n: int = 6001) -> FocalCue:
    """A box-shape-like cue at ``log f = m`` whose profile log likelihood is ``likelihood(x - m)``."""
    grid = np.linspace(m + lo, m + hi, n)
    lik = likelihood(grid - m)
    return FocalCue("box_shapes", float(np.exp(m)), 0.1, "profile", tuple(grid), tuple(lik - lik.max()))


def test_a_gaussian_profile_fuses_as_its_gaussian():
    """A cue whose profile is the Gaussian (log 900, 0.2) fuses with the prior (log 800, 0.3)
    as inverse variance does: mean and sigma to 0.1 % of the prior's sigma."""
    cue = _profile_cue(np.log(900.0), lambda d: -0.5 * (d / 0.2) ** 2)
    est = fuse_focal([FocalCue("prior", 800.0, 0.3, "p"), cue])
    w = np.array([1 / 0.09, 1 / 0.04])
    assert np.log(est.f_px) == pytest.approx((w @ np.log([800.0, 900.0])) / w.sum(), abs=3e-4)
    assert est.sigma_log == pytest.approx(1 / np.sqrt(w.sum()), abs=3e-4)


def test_a_one_sided_profile_keeps_its_skew():
    """Boxes that rule out focal lengths below f0 (Gaussian 0.1 on that side) and say nothing
    above it, with the prior centred on f0 (sigma 0.3): the posterior of log f is two half
    Gaussians of sigmas 0.3 and s_c = (1/0.3^2 + 1/0.1^2)^-1/2, whose mean lies
    (0.3 - s_c) / sqrt(pi / 2) above log f0 (0.164), not at f0 as the cue's Gaussian summary
    (f0, 0.1) would put it."""
    f0, s_p, s_b = 700.0, 0.3, 0.1
    cue = _profile_cue(np.log(f0), lambda d: np.where(d < 0, -0.5 * (d / s_b) ** 2, 0.0))
    est = fuse_focal([FocalCue("prior", f0, s_p, "p"), cue])
    s_c = 1 / np.sqrt(1 / s_p**2 + 1 / s_b**2)
    assert np.log(est.f_px / f0) == pytest.approx((s_p - s_c) / np.sqrt(np.pi / 2), abs=1e-3)
    # and a flat profile adds nothing: the prior comes back
    flat = _profile_cue(np.log(f0), lambda d: np.zeros_like(d))
    alone = fuse_focal([FocalCue("prior", 800.0, s_p, "p"), flat])
    assert alone.f_px == pytest.approx(800.0, rel=1e-3) and alone.sigma_log == pytest.approx(s_p, rel=1e-3)


def test_box_shape_cue_carries_its_profile():
    """The cue's profile peaks (0) within a grid step of the Laplace summary's f and lies on
    the searched focal lengths (``shape_focal_range`` of the diagonal)."""
    p = CameraParams()
    shapes = _kitti_boxes(721.0, 1.65, [(-4, 12), (3.5, 15), (-3, 25), (6, 20), (0.5, 30), (-7, 18)])
    cue = box_shape_cue(W, H, shapes, params=p)
    assert cue is not None and len(cue.profile_log_f) == p.shape_grid[0]
    grid, lik = np.array(cue.profile_log_f), np.array(cue.profile_log_lik)
    assert lik.max() == 0.0
    step = grid[1] - grid[0]
    assert abs(grid[np.argmax(lik)] - np.log(cue.f_px)) < 1.5 * step
    assert np.exp(grid[[0, -1]]) == pytest.approx(np.array(p.shape_focal_range) * np.hypot(W, H))


def test_profile_validation():
    with pytest.raises(CalibrationError, match="profile"):
        FocalCue("box_shapes", 700.0, 0.1, "x", (1.0, 2.0, 3.0), (0.0, 0.0))
    with pytest.raises(CalibrationError, match="profile"):
        FocalCue("box_shapes", 700.0, 0.1, "x", (3.0, 2.0, 1.0), (0.0, 0.0, 0.0))


def test_cars_across_the_street_pull_the_box_shapes_less():
    """Four cars along the street and two across it, off to the side (a junction's crossing
    traffic): read as cars along the street their wide boxes pull f short by 30-40 %; the
    along-or-across mixture (``shape_cross_fraction``) halves that pull and leaves f within
    the cue's stated spread."""
    car = CameraParams().shape_car_size_m
    for f_true, h_true in ((721.0, 1.65), (1100.0, 1.3)):
        for crossing in ([(8, 30), (12, 45)], [(10, 40), (-9, 35)]):
            along = _kitti_boxes(f_true, h_true, [(-4, 12), (3.5, 15), (-3, 25), (6, 20)], size=car)
            across = _kitti_boxes(f_true, h_true, crossing, size=(car[1], car[0], car[2]))
            n = len(along) + len(across)
            boxes = np.vstack([along.box_px, across.box_px])
            shapes = BoxShapes(boxes, np.tile(car, (n, 1)), np.full(n, 0.12))
            err = {}
            for share in (0.0, CameraParams().shape_cross_fraction):
                cue = box_shape_cue(W, H, shapes, params=CameraParams(shape_cross_fraction=share))
                assert cue is not None
                err[share] = np.log(cue.f_px / f_true)
            mixed = err[CameraParams().shape_cross_fraction]
            assert err[0.0] < -0.3
            assert abs(mixed) < 0.6 * abs(err[0.0]) and abs(mixed) < cue.sigma_log
