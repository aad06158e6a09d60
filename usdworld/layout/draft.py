"""The typed draft of one object's placement, and what the passes share.

A :class:`Draft` is everything known about one object between its first estimate and
collision resolution; it is frozen, and every pass of :func:`usdworld.layout.placement.place_objects`
returns new drafts (``dataclasses.replace``). :class:`DepthMethod` names what decided
the depth; what bounded it (the occluder it stands behind, the ordering rule that moved
it) sits in fields of its own and joins the method only in :attr:`Draft.depth_method`,
the string written to USD and ``report.json``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from usdworld.geometry.camera import PinholeCamera
from usdworld.geometry.rotation import turned
from usdworld.io.class_table import ClassTable
from usdworld.io.types import DepthMap
from usdworld.io.asset_catalogue import AssetSizes
from usdworld.layout.yaw import RoadAxis
from usdworld.parameters.collision import CollisionParams
from usdworld.parameters.perception import DEFAULT_PERCEPTION, PerceptionParams
from usdworld.parameters.placement import PlacementParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.perception.objects import ImageObject


class DepthMethod(enum.Enum):
    """What decided an object's depth (its value is the name written to USD)."""

    #: The seen ground contact held >= 80 % of the weight.
    CONTACT = "contact"
    #: Several cues fused, none dominant.
    FUSED = "fused"
    #: The dense depth map held >= 80 % of the weight.
    CNN = "cnn"
    #: The class-height prior held >= 80 % of the weight.
    HEIGHT = "height"
    #: Bottom hidden or cut: the visible bottom's ground point, an upper bound.
    CONTACT_PARTIAL = "contact_partial"
    #: Bottom hidden or cut: the depth the cut height gives, an upper bound.
    HEIGHT_PARTIAL = "height_partial"
    #: Bottom hidden: the top row and the class height.
    TOP_ROW = "top_row"
    #: Bottom cut by the image border: the cues still seen (top row, width across the
    #: image) within the cut contact's and cut height's bounds (:func:`usdworld.layout.cues.cut_off_front_depth`).
    CUT_OFF = "cut_off"
    #: Where its viewing ray meets its class's street row.
    STREET_LINE = "street_line"
    #: Just behind the object hiding its bottom (:attr:`Draft.behind`).
    BEHIND = "behind"
    #: No cue at all.
    UNPLACEABLE = "unplaceable"

    @property
    def is_partial(self) -> bool:
        """A cut or hidden bottom's bound from above, or the weak top-row estimate: never a
        lower bound for others, dropped beyond the world's range."""
        return self in _PARTIAL

    @property
    def is_ordered(self) -> bool:
        """Decided by the dense map (alone or for want of a bottom): the paper's ordering rules may change it."""
        return self in _ORDERED

    @property
    def is_seen_contact(self) -> bool:
        """Decided by a seen ground contact: such objects measure a street row."""
        return self in (DepthMethod.CONTACT, DepthMethod.FUSED)


_PARTIAL = frozenset(
    {DepthMethod.CONTACT_PARTIAL, DepthMethod.HEIGHT_PARTIAL, DepthMethod.TOP_ROW, DepthMethod.CUT_OFF}
)
_ORDERED = frozenset({DepthMethod.CNN, *_PARTIAL})


def method_confidence(method: DepthMethod, params: PlacementParams) -> float:
    """Confidence of a placement by what decided its depth (``PlacementParams.confidence_*``)."""
    return {
        DepthMethod.CONTACT: params.confidence_contact,
        DepthMethod.FUSED: params.confidence_fused,
        DepthMethod.CNN: params.confidence_cnn,
        DepthMethod.HEIGHT: params.confidence_height,
        DepthMethod.CONTACT_PARTIAL: params.confidence_contact_partial,
        DepthMethod.STREET_LINE: params.confidence_street_line,
        DepthMethod.TOP_ROW: params.confidence_top_row,
        DepthMethod.CUT_OFF: params.confidence_top_row,
        DepthMethod.BEHIND: params.confidence_behind,
        DepthMethod.HEIGHT_PARTIAL: params.confidence_height_partial,
        DepthMethod.UNPLACEABLE: 0.0,
    }[method]


def depth_method_label(method: DepthMethod, behind: str | None, rule: str) -> str:
    """The depth method as written to USD and ``report.json``: ``behind_<occluder>`` for
    :attr:`DepthMethod.BEHIND`, the method's value otherwise, with ``+<rule>`` when an
    ordering rule changed it (``cnn+rule1``, ``top_row+rule1+rule2``)."""
    base = f"behind_{behind}" if method is DepthMethod.BEHIND else method.value
    return f"{base}+{rule}" if rule else base


#: The collision defaults, for contexts made without them.
DEFAULT_COLLISION = CollisionParams()


@dataclass(frozen=True)
class PlacementContext:
    """What every pass of the placement reads: the camera, the ground, the class table and the thresholds.

    Attributes:
        camera: the source camera.
        ground_from_px: (3, 3) float64 homography from pixels to ground metres (DLT).
        axis: the road axis, for yaw and street rows.
        asset_sizes: asset sizes of every class that occurs.
        classes: the class table (priors and roles).
        params: the placement thresholds.
        depth_map: optional dense metric depth (adds the ``cnn`` cue and the ordering rules).
        camera_sigma: standard deviations of the camera height (m) and pitch (rad).
        sidewalk_lift: lift objects standing on the sidewalk to the kerb height.
        collision: the footprint collision thresholds.
        perception: the depth cues' error model and fusion (``object_depth_cues``, ``fuse``).
    """

    camera: PinholeCamera
    ground_from_px: np.ndarray
    axis: RoadAxis
    asset_sizes: dict[str, AssetSizes]
    classes: ClassTable
    params: PlacementParams
    depth_map: DepthMap | None = None
    camera_sigma: tuple[float, float] = (0.0, 0.0)
    sidewalk_lift: bool = True
    collision: CollisionParams = DEFAULT_COLLISION
    perception: PerceptionParams = DEFAULT_PERCEPTION


@dataclass(frozen=True)
class Forced:
    """A front depth the caller knows better than the object's own cues.

    Attributes:
        front_depth_m: depth of the object's front along the optical axis, metres.
        method: :attr:`DepthMethod.STREET_LINE` or :attr:`DepthMethod.BEHIND`.
        behind: the occluder's name for :attr:`DepthMethod.BEHIND`.
    """

    front_depth_m: float
    method: DepthMethod
    behind: str | None = None


@dataclass(frozen=True)
class Draft:
    """Everything about one object before collision resolution.

    Attributes:
        obj: the image evidence.
        name: prim name ``<class>_<NNNN>``.
        variant: asset variant chosen.
        ground: (2,) float64 footprint centre on the ground; for ``trunk`` classes the
            centre of the trunk's or post's contact (what the photo shows), which lies
            ``contact_offset`` from the asset's origin.
        yaw: rotation about Z, radians.
        yaw_source: how the yaw was chosen.
        scale: uniform scale applied to the asset.
        stretch: (3,) float64 factors on the uniform scale along the asset's axes.
        scale_measured: scale measured before clamping (NaN if not measurable).
        size: (3,) float64 size after scaling (length, width, height), metres.
        footprint: (2,) float64 what collides (a trunk's or post's contact for ``trunk`` classes).
        depth_m: centre depth along the optical axis, metres.
        method: what decided the depth.
        cues: every depth cue computed, as centre depths.
        confidence: in [0, 1].
        front_depth_m: depth of the object's front (contact row / visible surface), metres.
        back_m: centre depth minus front depth, metres.
        upper_m: a bound from above on the front depth (inf when none).
        behind: the occluder's name when ``method`` is :attr:`DepthMethod.BEHIND`.
        rule: ``''`` or the ordering rule(s) that changed the depth (``rule1``, ``rule1+rule2``).
        yaw_confidence: how sure the yaw's facing direction is, in [0, 1]
            (:class:`usdworld.layout.heading.Heading`).
        contact_offset: (2,) float64 where ``ground`` lies from the asset's origin, in the
            asset's frame at the object's scale, metres (a street lamp's mast; zero for
            classes placed by their origin): :meth:`origin` undoes it.
    """

    obj: ImageObject
    name: str
    variant: str
    ground: np.ndarray
    yaw: float
    yaw_source: str
    scale: float
    stretch: np.ndarray
    scale_measured: float
    size: np.ndarray
    footprint: np.ndarray
    depth_m: float
    method: DepthMethod
    cues: tuple[DepthCue, ...]
    confidence: float
    front_depth_m: float
    back_m: float
    upper_m: float
    behind: str | None = None
    rule: str = ""
    yaw_confidence: float = 1.0
    contact_offset: np.ndarray = field(default_factory=lambda: np.zeros(2))

    def origin(self, ground: np.ndarray, yaw: float) -> np.ndarray:
        """(2,) float64 asset origin of an object whose contact stands at ``ground`` turned by ``yaw``.

        Args:
            ground: (2,) float64 the contact's centre on the ground, metres.
            yaw: rotation about Z, radians.
        """
        return np.asarray(ground, dtype=np.float64)[:2] - turned(self.contact_offset, yaw)

    @property
    def depth_method(self) -> str:
        """The method as written to USD (:func:`depth_method_label`)."""
        return depth_method_label(self.method, self.behind, self.rule)


def depth_of_ground_point(camera: PinholeCamera, p_ground: np.ndarray) -> float:
    """Optical-axis depth of a ground point, metres.

    Args:
        camera: the source camera.
        p_ground: (2,) float64 ground point.
    """
    return float(camera.cam_from_world_points(np.array([[p_ground[0], p_ground[1], 0.0]]))[0, 2])


def point_at_depth(camera: PinholeCamera, u: float, v: float, depth: float) -> np.ndarray:
    """Ground point below the point at ``depth`` on the ray of pixel (u, v); (2,) float64."""
    ray = camera.rays_world(np.array([[u, v]]))[0]
    p = camera.center_world + ray * depth
    return p[:2]
