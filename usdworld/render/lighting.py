"""Sun, ambient and sky settings, and the sun's shadow-map box.

The sun is a directional light; ``sun_direction_world`` points from the ground **towards**
the sun. The default sun stands 45 degrees high behind the camera's left shoulder
(azimuth 135 degrees from world +X towards +Y), so shadows fall forwards and to the right,
into a camera looking along +X.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usdworld.errors import UsdWorldError
from usdworld.perception.colour_space import linear_to_srgb


def sun_direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """(3,) float64 unit vector towards the sun.

    Args:
        azimuth_deg: degrees from world +X towards +Y (left).
        elevation_deg: degrees above the horizon.
    """
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def _vec3(value: object, name: str) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise UsdWorldError(f"Lighting.{name}: must be 3 finite numbers, got {value!r}")
    a = a.copy()
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Lighting:
    """How a scene is lit (Blinn-Phong + hemisphere ambient + one shadowing sun).

    Attributes:
        sun_direction_world: (3,) towards the sun (normalised on construction; z > 0).
        sun_color: (3,) linear RGB intensity of the sun.
        sky_ambient: (3,) linear ambient light from above.
        ground_ambient: (3,) linear ambient light from below.
        specular: strength of the Blinn-Phong highlight.
        shininess: Blinn-Phong exponent.
        gamma: display gamma applied to the linear result.
        sky_zenith_srgb: (3,) sRGB sky colour straight up, in [0, 1].
        sky_horizon_srgb: (3,) sRGB sky colour at the horizon, in [0, 1].
        shadow_map_size: side of the square shadow map, texels.
        shadow_distance_m: the shadow map covers the view frustum up to this distance
            (clipped to the scene); None covers the whole scene.
    """

    sun_direction_world: np.ndarray = field(default_factory=lambda: sun_direction(135.0, 45.0))
    sun_color: np.ndarray = field(default_factory=lambda: np.array([1.1, 1.05, 0.95]))
    sky_ambient: np.ndarray = field(default_factory=lambda: np.array([0.30, 0.33, 0.40]))
    ground_ambient: np.ndarray = field(default_factory=lambda: np.array([0.18, 0.17, 0.16]))
    specular: float = 0.15
    shininess: float = 32.0
    gamma: float = 2.2
    sky_zenith_srgb: np.ndarray = field(default_factory=lambda: np.array([0.33, 0.52, 0.80]))
    sky_horizon_srgb: np.ndarray = field(default_factory=lambda: np.array([0.78, 0.85, 0.93]))
    shadow_map_size: int = 2048
    shadow_distance_m: float | None = 120.0

    def __post_init__(self) -> None:
        for name in (
            "sun_direction_world",
            "sun_color",
            "sky_ambient",
            "ground_ambient",
            "sky_zenith_srgb",
            "sky_horizon_srgb",
        ):
            object.__setattr__(self, name, _vec3(getattr(self, name), name))
        d = self.sun_direction_world
        if not d[2] > 1e-3 * np.linalg.norm(d):
            raise UsdWorldError(
                f"Lighting.sun_direction_world: the sun must be above the horizon (z > 0), got {d}"
            )
        unit = d / np.linalg.norm(d)
        unit.setflags(write=False)
        object.__setattr__(self, "sun_direction_world", unit)
        if not (self.gamma > 0 and self.shininess > 0 and self.specular >= 0):
            raise UsdWorldError("Lighting: gamma and shininess must be > 0 and specular >= 0")
        if not 16 <= self.shadow_map_size <= 16384:
            raise UsdWorldError(f"Lighting.shadow_map_size: must be in 16..16384, got {self.shadow_map_size}")
        if self.shadow_distance_m is not None and not self.shadow_distance_m > 0:
            raise UsdWorldError(
                f"Lighting.shadow_distance_m: must be > 0 or None, got {self.shadow_distance_m}"
            )


def irradiance(lighting: Lighting, normal_world: np.ndarray) -> np.ndarray:
    """The light the colour shader (:data:`~usdworld.render.shaders.LIT_FS`) gives an unshadowed surface.

    ``ambient(n) + sun_color * max(n . sun, 0)``, where the ambient light blends the ground's
    into the sky's as the normal turns up.

    Args:
        lighting: the lighting.
        normal_world: (3,) float surface normal (normalised here).

    Returns:
        (3,) float64 linear RGB irradiance (the factor the albedo is multiplied by).
    """
    n = np.asarray(normal_world, dtype=np.float64)
    n = n / np.linalg.norm(n)
    t = 0.5 + 0.5 * n[2]
    ambient = (1.0 - t) * lighting.ground_ambient + t * lighting.sky_ambient
    return ambient + lighting.sun_color * max(float(n @ lighting.sun_direction_world), 0.0)


def albedo_for_photo(shown_linear: np.ndarray, normal_world: np.ndarray, lighting: Lighting) -> np.ndarray:
    """The albedo whose render reproduces a colour seen in the photo.

    Inverts the colour shader for a lit surface with the given normal: the photo shows
    ``srgb(shown_linear)``; the renderer shows ``(albedo * irradiance) ** (1 / gamma)``
    (its Blinn-Phong highlight left aside: on a surface facing the camera it adds under
    0.2 % with the default sun). So ``albedo = srgb(shown_linear) ** gamma / irradiance``,
    clipped to [0, 1] (a colour brighter than a white surface in that light gives white).

    Args:
        shown_linear: (3,) float linear RGB measured in the photo (sRGB decoded).
        normal_world: (3,) float normal of the surface the colour is matched on.
        lighting: the lighting the world is rendered with.

    Returns:
        (3,) float64 linear albedo in [0, 1].
    """
    shown = linear_to_srgb(np.asarray(shown_linear, dtype=np.float64))
    return np.clip(shown**lighting.gamma / irradiance(lighting, normal_world), 0.0, 1.0)


def overcast_lighting(sun_direction_world: np.ndarray | None = None) -> Lighting:
    """The lighting of an overcast day: no direct sun, a bright grey sky all round.

    The sun's light is spread over the sky dome: the upward ambient is the default sun's
    irradiance on the ground (45 degrees high) plus the default sky's, so a camera exposed
    for the ground sees it about as bright as on a sunny day, and nothing casts a shadow
    (the sun term is zero; the direction only places the unused shadow map).

    Args:
        sun_direction_world: (3,) where the hidden sun stands (default: the default sun's).

    Returns:
        The lighting.
    """
    sunny = Lighting()
    up = sunny.sky_ambient + sunny.sun_color * np.sin(np.radians(45.0))
    return Lighting(
        sun_direction_world=sunny.sun_direction_world if sun_direction_world is None else sun_direction_world,
        sun_color=np.zeros(3),
        sky_ambient=up,
        ground_ambient=sunny.ground_ambient * float(np.mean(up / sunny.sky_ambient)),
        specular=0.0,
        sky_zenith_srgb=np.array([0.72, 0.74, 0.77]),
        sky_horizon_srgb=np.array([0.86, 0.87, 0.88]),
    )


def _box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def frustum_corners_world(
    K: np.ndarray, world_from_cam: np.ndarray, width: int, height: int, near: float, far: float
) -> np.ndarray:
    """(8, 3) float64 corners of the view frustum between depths ``near`` and ``far``."""
    px = np.array([[0.0, 0.0], [width, 0.0], [0.0, height], [width, height]]) - 0.5
    rays = np.column_stack([px, np.ones(4)]) @ np.linalg.inv(K).T  # depth 1
    cam = np.concatenate([rays * near, rays * far])
    return cam @ world_from_cam[:3, :3].T + world_from_cam[:3, 3]


def _light_from_world(lighting: Lighting) -> np.ndarray:
    """(3, 3) rotation world -> sun frame (x, y across the sun's rays, z towards the sun)."""
    d = lighting.sun_direction_world
    up = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    x_axis = np.cross(up, d)
    x_axis /= np.linalg.norm(x_axis)
    y_axis = np.cross(d, x_axis)
    return np.stack([x_axis, y_axis, d])


def _view_box_light(
    lighting: Lighting,
    light_from_world: np.ndarray,
    scene_l: np.ndarray,
    K: np.ndarray,
    world_from_cam: np.ndarray,
    width: int,
    height: int,
) -> tuple[np.ndarray, np.ndarray]:
    """(2,) lower and (2,) upper corner, in the sun frame, of the box one view's shadows need."""
    xy_lo, xy_hi = scene_l[:, :2].min(axis=0), scene_l[:, :2].max(axis=0)
    if lighting.shadow_distance_m is not None:
        frustum = frustum_corners_world(K, world_from_cam, width, height, 0.05, lighting.shadow_distance_m)
        fr_l = frustum @ light_from_world.T
        view_lo = np.maximum(xy_lo, fr_l[:, :2].min(axis=0))
        view_hi = np.minimum(xy_hi, fr_l[:, :2].max(axis=0))
        if np.all(view_hi > view_lo):  # else the camera looks away from the scene: the whole scene
            xy_lo, xy_hi = view_lo, view_hi
    return xy_lo, xy_hi


def _ortho_view_projection(
    light_from_world: np.ndarray, xy_lo: np.ndarray, xy_hi: np.ndarray, scene_l: np.ndarray
) -> np.ndarray:
    """(4, 4) world -> shadow clip space of the sun box ``xy_lo..xy_hi`` spanning the scene along the rays."""
    light = np.eye(4)
    light[:3, :3] = light_from_world
    z_lo, z_hi = scene_l[:, 2].min() - 1.0, scene_l[:, 2].max() + 1.0
    ortho = np.eye(4)
    ortho[0, 0] = 2.0 / (xy_hi[0] - xy_lo[0])
    ortho[1, 1] = 2.0 / (xy_hi[1] - xy_lo[1])
    ortho[2, 2] = -2.0 / (z_hi - z_lo)  # GL: nearer the sun (larger z) -> smaller depth
    ortho[0, 3] = -(xy_hi[0] + xy_lo[0]) / (xy_hi[0] - xy_lo[0])
    ortho[1, 3] = -(xy_hi[1] + xy_lo[1]) / (xy_hi[1] - xy_lo[1])
    ortho[2, 3] = (z_hi + z_lo) / (z_hi - z_lo)
    return ortho @ light


def sun_view_projection(
    lighting: Lighting,
    bounds_world: np.ndarray,
    K: np.ndarray,
    world_from_cam: np.ndarray,
    width: int,
    height: int,
) -> tuple[np.ndarray, float]:
    """The sun's orthographic view-projection and the size of one shadow texel.

    The box spans the whole scene along the sun direction (so every caster is in it) and,
    across it, the part of the scene the camera sees up to ``shadow_distance_m``.

    Args:
        lighting: sun direction and shadow settings.
        bounds_world: (2, 3) float64 scene bounds ``[min, max]``.
        K: (3, 3) float64 camera matrix.
        world_from_cam: (4, 4) float64 camera pose.
        width: image width in pixels.
        height: image height in pixels.

    Returns:
        (4, 4) float64 matrix world -> shadow clip space, and the texel size in metres.
    """
    light_from_world = _light_from_world(lighting)
    scene_l = _box_corners(bounds_world[0] - 0.5, bounds_world[1] + 0.5) @ light_from_world.T
    xy_lo, xy_hi = _view_box_light(lighting, light_from_world, scene_l, K, world_from_cam, width, height)
    texel = float(max(xy_hi - xy_lo) / lighting.shadow_map_size)
    return _ortho_view_projection(light_from_world, xy_lo, xy_hi, scene_l), texel


@dataclass(frozen=True)
class PathShadow:
    """One shadow map for every view of a camera path over a static scene.

    Attributes:
        sun_vp: (4, 4) float64 world -> shadow clip space.
        map_size: side of the square shadow map, texels.
        texel_m: (2,) float64 texel size across the sun's rays (sun-frame x, y), metres.
        first_view_texel_m: (2,) float64 the texel size the first view has on its own
            (:func:`sun_view_projection` with ``lighting.shadow_map_size``), metres.
    """

    sun_vp: np.ndarray
    map_size: int
    texel_m: np.ndarray
    first_view_texel_m: np.ndarray


def path_shadow(
    lighting: Lighting,
    bounds_world: np.ndarray,
    K: np.ndarray,
    poses_world_from_cam: np.ndarray,
    width: int,
    height: int,
    max_map_size: int,
) -> PathShadow:
    """A shadow box that holds every view's own box, with texels no coarser than the first view's.

    The box is the union, in the sun's frame, of the boxes :func:`sun_view_projection`
    gives each view, so every shadow a view would have drawn is in it. The map is made
    large enough (up to ``max_map_size``) that along both axes a texel is no larger than
    the first view's own, which is the one the source camera sees.

    Args:
        lighting: sun direction and shadow settings.
        bounds_world: (2, 3) float64 scene bounds ``[min, max]``.
        K: (3, 3) float64 camera matrix of every view.
        poses_world_from_cam: (N, 4, 4) float64 camera poses, the first being the reference view (N >= 1).
        width: image width in pixels.
        height: image height in pixels.
        max_map_size: largest shadow map side allowed (the GL texture limit); when it binds
            the texels are coarser than the first view's.

    Returns:
        The box's projection, map size and texel sizes.
    """
    poses = np.asarray(poses_world_from_cam, dtype=np.float64).reshape(-1, 4, 4)
    if len(poses) == 0:
        raise UsdWorldError("path_shadow: needs at least one pose")
    light_from_world = _light_from_world(lighting)
    scene_l = _box_corners(bounds_world[0] - 0.5, bounds_world[1] + 0.5) @ light_from_world.T
    boxes = np.array(
        [_view_box_light(lighting, light_from_world, scene_l, K, T, width, height) for T in poses]
    )
    xy_lo, xy_hi = boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)
    first = (boxes[0, 1] - boxes[0, 0]) / lighting.shadow_map_size
    size = int(np.ceil(np.max((xy_hi - xy_lo) / first) - 1e-9))
    size = min(max(size, lighting.shadow_map_size), int(max_map_size))
    return PathShadow(
        sun_vp=_ortho_view_projection(light_from_world, xy_lo, xy_hi, scene_l),
        map_size=size,
        texel_m=(xy_hi - xy_lo) / size,
        first_view_texel_m=first,
    )
