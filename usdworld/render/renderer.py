"""The moderngl renderer: shadow map, lit colour, and exact ids + metric depth.

Example:
    >>> scene = RenderScene.from_stage(stage)                      # doctest: +SKIP
    >>> with Renderer(1024, 512) as renderer:                      # doctest: +SKIP
    ...     result = renderer.render(scene, camera.K, camera.world_from_cam())
    >>> result.rgb.shape, result.class_ids.dtype                   # doctest: +SKIP
    ((512, 1024, 3), dtype('int32'))

Passes (one draw call per mesh batch each; no multisampling anywhere, so every id pixel is exact):

1. shadow: depth from an orthographic sun camera into a ``shadow_map_size``\u00b2 depth texture;
   its box follows the view, or is fixed once for a whole camera path over a static scene
   (:meth:`Renderer.fix_shadow_box`: the fly-through draws it once); instances whose box lies
   beyond a side of the sun's box make no fragment and are not drawn
   (:func:`~usdworld.render.occlusion.outside_clip_sides`);
2. labels: class id, instance id and object index as int32 and the OpenCV camera depth
   ``z`` in metres as float32 (0 where no surface was hit) in one multi-target pass; after
   :meth:`Renderer.render`'s occlusion test it keeps the occluders' depth (the fragments behind
   them fail the test and are not shaded) and draws last to first with "<=", so that the first
   of the fragments at a pixel's nearest depth wins, as in one "<" pass from a cleared buffer;
3. colour: Blinn-Phong + hemisphere ambient with a 3x3 PCF shadow lookup (normal offset +
   small bias; four bilinear depth comparisons; ``shadow_taps=1``: one, a 2x2 PCF, which the
   fly-through uses), gamma-encoded to 8 bits, shading only the nearest surface of each pixel
   against a depth pre-pass (in :meth:`Renderer.render`, the label pass's depth;
   :meth:`Renderer.render_rgb` draws its own), then the sky gradient where no surface was drawn;
   after :meth:`Renderer.render`'s occlusion test, of the objects' instances only those of the
   objects that won a pixel in the labels (the same winner at every pixel, so the same colour);
   ``cull_back_faces`` (the fly-through's) leaves out of :meth:`Renderer.render_rgb`'s two
   passes the faces of closed meshes turned away from the camera; ``near_first`` (the
   fly-through's) draws no pre-pass there: the lit pass draws near surfaces first and writes
   the depth (:meth:`_SceneBuffers.draw_near_first`).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Self

import numpy as np

from usdworld.errors import UsdWorldError
from usdworld.parameters.rendering import RenderingParams
from usdworld.render import shaders
from usdworld.render.camera import check_intrinsics, gl_projection, gl_view
from usdworld.render.context import RenderError, create_context
from usdworld.render.lighting import Lighting, PathShadow, path_shadow, sun_view_projection
from usdworld.render.batches import MeshBatch
from usdworld.render.occlusion import (
    SUN_MARGIN_TEXELS,
    DepthPyramid,
    hidden,
    instance_corners,
    occluders,
    outside_clip_sides,
    project_boxes,
)
from usdworld.render.scene import RenderScene
from usdworld.render.winding import culled_face, outward_winding

log = logging.getLogger(__name__)

#: Largest image side the renderer accepts (llvmpipe's framebuffer limit is 16384).
MAX_SIZE = 8192

#: Steps of a 24-bit depth buffer every surface's window depth must lie below the far plane's 1
#: by for the label pass to keep the occluders' depth and test "<=" (the rounding of the window
#: depth is half a step; geometry of the depth format, not tuned).
FAR_MARGIN = 4.0 / (1 << 24)

#: Shadow filters: bilinear depth comparisons per shaded pixel -> the lit program's source.
_SHADOW_FILTERS = {4: "LIT_FS", 1: "LIT_BILINEAR_FS"}


@dataclass(frozen=True)
class RenderResult:
    """All passes of one view.

    Attributes:
        rgb: (H, W, 3) uint8 lit colour, sRGB-ish (gamma-encoded).
        class_ids: (H, W) int32 Cityscapes label id; 0 where nothing was hit.
        instance_ids: (H, W) int32 Cityscapes instance id; 0 where nothing was hit.
        object_ids: (H, W) int32 1-based index into ``RenderScene.objects``; 0: no object.
        depth_m: (H, W) float32 depth along the optical axis, metres; 0 where nothing was hit.
    """

    rgb: np.ndarray
    class_ids: np.ndarray
    instance_ids: np.ndarray
    object_ids: np.ndarray
    depth_m: np.ndarray


def _write(prog: Any, name: str, value: np.ndarray | float) -> None:
    """Set a uniform; matrices are uploaded column-major. Unused uniforms are skipped."""
    if name not in prog:
        return
    if isinstance(value, np.ndarray):
        prog[name].write(np.ascontiguousarray(value.T if value.ndim == 2 else value, dtype="f4").tobytes())
    else:
        prog[name].value = value


def _sunlit(lighting: Lighting) -> bool:
    """Whether the sun adds any light (an overcast world's sun colour is 0)."""
    return bool(np.any(np.asarray(lighting.sun_color) != 0))


#: One instance's record in the instance buffer: the top three rows of world_from_local
#: (double), the columns of its linear part's cofactor matrix (normals), its ids and its colour.
_INSTANCE = np.dtype(
    [("rows", "<f8", (3, 4)), ("normal", "<f4", (3, 3)), ("ids", "<i4", 3), ("color", "<f4", 3)]
)
_ROWS = "4f8 4f8 4f8"
_ROW_NAMES = ("in_r0", "in_r1", "in_r2")


def _instance_records(batch: MeshBatch) -> np.ndarray:
    n = batch.n_instances
    rec = np.zeros(n, dtype=_INSTANCE)
    m = batch.world_from_local
    rec["rows"] = m[:, :3, :]
    c0, c1, c2 = (m[:, :3, k] for k in range(3))  # the linear part's columns
    # its cofactor matrix, det * inverse transpose (columns c1 x c2, c2 x c0, c0 x c1): it turns a
    # normal as the inverse transpose does, up to length and sign, and a flattening scale too
    cofactor = np.stack([np.cross(c1, c2), np.cross(c2, c0), np.cross(c0, c1)], axis=2)
    rec["normal"] = np.transpose(cofactor, (0, 2, 1))  # columns, as GLSL's mat3(c0, c1, c2) takes them
    rec["ids"] = np.stack([batch.class_ids, batch.instance_ids, batch.object_ids], axis=1)
    if batch.instance_colors is not None:
        rec["color"] = batch.instance_colors
    return rec


class _BatchBuffers:
    """One batch on the GPU: its corners once, its instances, a vertex array per pass."""

    def __init__(self, ctx: Any, batch: MeshBatch, programs: dict[str, Any]) -> None:
        self.batch = batch
        self.n_instances = batch.n_instances
        corners = batch.corners_local()
        normals = batch.normals_local if batch.normals_local is not None else batch.flat_normals_local()
        pos = ctx.buffer(np.ascontiguousarray(corners, dtype="f8").tobytes())
        nrm = ctx.buffer(np.ascontiguousarray(normals, dtype="f4").tobytes())
        self._records = _instance_records(batch)
        # the shadow map draws the instances in the sun's box; the camera's passes those shown
        # (all until told)
        inst_all = ctx.buffer(self._records.tobytes())
        self._sun = inst_all
        self.n_sunlit = self.n_instances
        self._sunlit: np.ndarray | None = None
        inst = ctx.buffer(self._records.tobytes())
        inst_rev = ctx.buffer(self._records[::-1].tobytes())
        self._camera = (inst, inst_rev)
        self.n_shown = self.n_instances
        self._shown: np.ndarray | None = None
        # The colour pass draws the triangles last to first after a depth pre-pass: with the "<="
        # test the last of the fragments at the nearest depth wins, which in reverse order is the
        # first, as in one "<" pass (so where two surfaces tie in depth the same one shows).
        n_tri = len(corners) // 3
        last_first = np.arange(n_tri - 1, -1, -1, dtype=np.int32)[:, None] * 3
        ibo = ctx.buffer((last_first + np.arange(3, dtype=np.int32)).ravel().tobytes())
        self._corners_world: np.ndarray | None = None
        self._boxes_world: np.ndarray | None = None
        self._centres_world: np.ndarray | None = None
        #: the order the lit pass draws the instances in (``show_near_first``); None: last to first
        self._lit_order: np.ndarray | None = None
        self._cull_face: str | None | bool = False  # False: not worked out yet
        self.buffers = [pos, nrm, inst_all, inst, inst_rev, ibo]
        place = f"{_ROWS} {_INSTANCE.itemsize - 96}x/i"
        placed = [(pos, "3f8", "in_pos"), (inst, place, *_ROW_NAMES)]
        ids = f"{_ROWS} 36x 3i 12x/i"
        self.vaos: dict[str, Any] = {
            "shadow": ctx.vertex_array(
                programs["shadow"], [(pos, "3f8", "in_pos"), (inst_all, place, *_ROW_NAMES)]
            ),
            "depth": ctx.vertex_array(programs["depth"], placed),
            "label": ctx.vertex_array(
                programs["label"], [(pos, "3f8", "in_pos"), (inst, ids, *_ROW_NAMES, "in_ids")]
            ),
            "label_last_first": ctx.vertex_array(
                programs["label"],
                [(pos, "3f8", "in_pos"), (inst_rev, ids, *_ROW_NAMES, "in_ids")],
                index_buffer=ibo,
                index_element_size=4,
            ),
        }
        lit = [(pos, "3f8", "in_pos"), (nrm, "3f", "in_normal")]
        names = (*_ROW_NAMES, "in_n0", "in_n1", "in_n2")
        if batch.vertex_colors is not None:
            col = ctx.buffer(np.ascontiguousarray(batch.vertex_colors, dtype="f4").tobytes())
            self.buffers.append(col)
            lit += [(col, "3f", "in_color"), (inst_rev, f"{_ROWS} 3f 3f 3f 24x/i", *names)]
        else:
            lit += [(inst_rev, f"{_ROWS} 3f 3f 3f 12x 3f/i", *names, "in_color")]
        for name in ("lit", "lit_ambient"):
            self.vaos[name] = ctx.vertex_array(programs[name], lit, index_buffer=ibo, index_element_size=4)

    def corners_world(self) -> np.ndarray:
        """(N, 8, 3) float64 each instance's box corners (:func:`.occlusion.instance_corners`), kept."""
        if self._corners_world is None:
            self._corners_world = instance_corners(self.batch)
        return self._corners_world

    def cull_face(self) -> str | None:
        """The face every instance may drop seen from outside (:func:`.winding.culled_face`), kept."""
        if self._cull_face is False:
            self._cull_face = culled_face(outward_winding(self.batch.topology), self.batch.world_from_local)
        return self._cull_face

    def boxes_world(self) -> np.ndarray:
        """(N, 2, 3) float64 each instance's axis-aligned box ``[min, max]`` in the world, kept."""
        if self._boxes_world is None:
            corners = self.corners_world()
            self._boxes_world = np.stack([corners.min(axis=1), corners.max(axis=1)], axis=1)
        return self._boxes_world

    def centres_world(self) -> np.ndarray:
        """(N, 3) float64 the centre of each instance's axis-aligned box in the world, kept."""
        if self._centres_world is None:
            self._centres_world = self.boxes_world().mean(axis=1)
        return self._centres_world

    def show(self, shown: np.ndarray | None) -> None:
        """Let the camera's passes draw only the instances where ``shown`` ((N,) bool) is True; None: all.

        The shown instances keep their order (and the lit pass its reverse order).
        """
        if self._lit_order is None:
            if shown is None and self._shown is None:
                return
            if shown is not None and self._shown is not None and np.array_equal(shown, self._shown):
                return
        self._lit_order = None
        records = self._records if shown is None else self._records[shown]
        inst, inst_rev = self._camera
        if len(records):
            inst.write(records.tobytes())
            inst_rev.write(records[::-1].tobytes())
        self.n_shown = len(records)
        self._shown = None if shown is None else shown.copy()

    def show_near_first(self, order: np.ndarray) -> None:
        """Let the camera's passes draw every instance, the lit pass in ``order`` ((N,) int, a permutation).

        The other camera passes keep the scene's order (:meth:`show` with None).
        """
        if self._shown is not None:  # the forward buffer holds a subset: every instance again
            self._camera[0].write(self._records.tobytes())
            self.n_shown, self._shown = self.n_instances, None
        if self._lit_order is not None and np.array_equal(order, self._lit_order):
            return
        self._camera[1].write(self._records[order].tobytes())
        self._lit_order = np.array(order, copy=True)

    def show_to_sun(self, inside: np.ndarray | None) -> None:
        """Let the shadow map draw only the instances where ``inside`` ((N,) bool) is True; None: all."""
        if inside is not None and inside.all():
            inside = None  # the buffer keeps every instance: nothing to write
        if inside is None and self._sunlit is None:
            return
        if inside is not None and self._sunlit is not None and np.array_equal(inside, self._sunlit):
            return
        records = self._records if inside is None else self._records[inside]
        if len(records):
            self._sun.write(records.tobytes())
        self.n_sunlit = len(records)
        self._sunlit = None if inside is None else inside.copy()

    def render(self, ctx: Any, name: str) -> None:
        n = self.n_sunlit if name == "shadow" else self.n_shown
        if n:
            self.vaos[name].render(mode=ctx.TRIANGLES, instances=n)

    def release(self) -> None:
        for vao in self.vaos.values():
            vao.release()
        for buf in self.buffers:
            buf.release()
        self.vaos, self.buffers = {}, []


def _of_objects_seen(
    object_ids: np.ndarray, shown: list[np.ndarray], batches: list[_BatchBuffers]
) -> list[np.ndarray]:
    """Per batch, (N,) bool the ``shown`` instances that are no object's or whose object won a pixel.

    Args:
        object_ids: (H, W) int32 the label pass's object index per pixel (0: no object).
        shown: per batch, (N,) bool the instances the label pass drew.
        batches: the batches on the GPU, in the same order.
    """
    top = max([int(object_ids.max(initial=0))] + [int(b.batch.object_ids.max(initial=0)) for b in batches])
    seen = np.bincount(object_ids.ravel(), minlength=top + 1) > 0
    seen[0] = True  # the ground and the stuff that is no object
    return [mask & seen[b.batch.object_ids] for b, mask in zip(batches, shown, strict=True)]


class _SceneBuffers:
    """The GPU copy of one RenderScene (kept while the same scene object is rendered)."""

    def __init__(self, ctx: Any, scene: RenderScene, programs: dict[str, Any]) -> None:
        self.scene = scene
        self.batches = [_BatchBuffers(ctx, b, programs) for b in scene.batches if b.n_instances]
        self.n_vertices = sum(b.n_corners * b.n_instances for b in scene.batches)
        #: per batch, the face its draws cull (``"back"`` / ``"front"``) or None; None: no culling
        self.culled: list[str | None] | None = None
        #: the batches that place their meshes with the same transforms (one asset's parts), in
        #: scene order, each group in the order of its first batch
        self.groups: list[list[int]] = _same_placement_groups(self.batches)
        #: the batch indices in the order the last :meth:`draw_near_first` drew them
        self.last_order: list[int] | None = None
        self._boxes: tuple[np.ndarray, np.ndarray] | None = None

    def instance_boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """Every batch's instance boxes in batch order, kept: (M, 8, 3) float64 corners
        (:meth:`_BatchBuffers.corners_world`) and (M,) int64 the triangles of each one's mesh."""
        if self._boxes is None:
            corners = [b.corners_world() for b in self.batches]
            triangles = [np.full(b.n_instances, b.batch.n_corners // 3, dtype=np.int64) for b in self.batches]
            empty = (np.zeros((0, 8, 3)), np.zeros(0, dtype=np.int64))
            self._boxes = (np.concatenate(corners), np.concatenate(triangles)) if corners else empty
        return self._boxes

    def instance_splits(self) -> np.ndarray:
        """(B - 1,) int64 where each batch's instances start in :meth:`instance_boxes`, the first left out
        (``np.split``'s indices)."""
        return np.cumsum([b.n_instances for b in self.batches[:-1]], dtype=np.int64)

    def draw(self, ctx: Any, name: str) -> None:
        """One pass over every batch: in scene order, the lit pass (and a ``*last_first`` pass) last
        to first (see above), each batch with the face :attr:`culled` gives it culled."""
        last_first = name.startswith("lit") or name.endswith("last_first")
        order = range(len(self.batches) - 1, -1, -1) if last_first else range(len(self.batches))
        self._draw_batches(ctx, name, order)

    def _draw_batches(self, ctx: Any, name: str, order: Iterable[int]) -> None:
        """Pass ``name`` over the batches of ``order``, each with the face :attr:`culled` gives it culled."""
        culled = self.culled
        for i in order:
            face = culled[i] if culled is not None else None
            if face is not None:
                ctx.enable(ctx.CULL_FACE)
                ctx.cull_face = face
            self.batches[i].render(ctx, name)
            if face is not None:
                ctx.disable(ctx.CULL_FACE)

    def draw_near_first(self, ctx: Any, name: str, eye: np.ndarray) -> None:
        """The lit pass ``name`` without a depth pre-pass, near surfaces first (the caller tests "<=").

        The groups of batches (:attr:`groups`) are drawn nearest first (by the nearest centre of
        their instances' boxes from ``eye``, (3,) float64), each group's batches last to first and
        each batch's instances nearest first, every batch with its triangles last to first: a
        fragment hidden by one already drawn fails the depth test and is not shaded. Where two
        surfaces of one asset's parts (one group: the same instances) tie in depth, the "<=" test
        lets the last drawn win, which is the first in the scene's order, as after a pre-pass.
        """
        nearest = []
        for b in self.batches:
            dist = np.linalg.norm(b.centres_world() - eye, axis=1)
            b.show_near_first(np.argsort(dist, kind="stable"))
            nearest.append(float(dist.min()))
        first = [min(nearest[i] for i in group) for group in self.groups]
        order = [i for g in np.argsort(first, kind="stable") for i in reversed(self.groups[g])]
        self._draw_batches(ctx, name, order)
        self.last_order = order

    def release(self) -> None:
        for b in self.batches:
            b.release()
        self.batches = []


def _same_placement_groups(batches: list[_BatchBuffers]) -> list[list[int]]:
    """Indices of ``batches`` grouped by equal ``world_from_local`` ((N, 4, 4) arrays, bit for bit)."""
    groups: dict[bytes, list[int]] = {}
    for i, b in enumerate(batches):
        groups.setdefault(np.ascontiguousarray(b.batch.world_from_local).tobytes(), []).append(i)
    return list(groups.values())


class Renderer:
    """Offscreen renderer for one image size; use as a context manager (owns a GL context).

    Args:
        width: image width in pixels.
        height: image height in pixels.
        lighting: sun, ambient, sky and shadow settings (default :class:`Lighting`).
        near_m: near clipping distance in metres (surfaces closer than this are cut).
        occlusion_cull: :meth:`render` leaves out of the label and colour passes the instances
            hidden behind the big ones (:mod:`usdworld.render.occlusion`; the same pixels) in a
            scene of many triangles (``rendering.occlusion_min_triangles_per_px``); False draws
            every instance in every pass.
        rendering: the renderer's speed settings (default :class:`RenderingParams`).
        shadow_taps: the colour pass's shadow filter: 4 bilinear depth comparisons (a 3x3 PCF)
            or 1 (a 2x2 PCF, cheaper, with slightly harder shadow edges: the fly-through's,
            :attr:`~usdworld.parameters.video.VideoParams.shadow_taps`).
        cull_back_faces: :meth:`render_rgb` leaves out of its depth pre-pass and lit pass the
            faces of closed meshes turned away from the camera (:mod:`usdworld.render.winding`),
            for every batch whose instances' boxes, widened by the near plane's reach, all
            leave the camera outside: the same surfaces show, but half of each closed mesh is
            not rasterised. Pixels change only where a face ties in depth with another or a
            pixel centre falls on a silhouette edge (the fly-through's,
            :attr:`~usdworld.parameters.video.VideoParams.cull_back_faces`). :meth:`render`
            never culls.
        near_first: :meth:`render_rgb` draws no depth pre-pass: its lit pass draws the scene
            near surfaces first (:meth:`_SceneBuffers.draw_near_first`) and writes the depth, so
            that most hidden fragments fail the depth test unshaded. The same surfaces show;
            pixels change only where surfaces of different assets, or two instances of one
            mesh, tie in depth (the fly-through's,
            :attr:`~usdworld.parameters.video.VideoParams.near_first`). :meth:`render` keeps its
            label pass's depth.

    Raises:
        RenderError: no usable headless OpenGL (the message names the packages to install).
    """

    def __init__(
        self,
        width: int,
        height: int,
        lighting: Lighting | None = None,
        near_m: float = 0.1,
        occlusion_cull: bool = True,
        rendering: RenderingParams | None = None,
        shadow_taps: int = 4,
        cull_back_faces: bool = False,
        near_first: bool = False,
    ) -> None:
        if not (0 < int(width) <= MAX_SIZE and 0 < int(height) <= MAX_SIZE):
            raise UsdWorldError(f"render size must be 1..{MAX_SIZE} pixels per side, got {width}x{height}")
        if not near_m > 0:
            raise UsdWorldError(f"near_m must be > 0, got {near_m}")
        if shadow_taps not in _SHADOW_FILTERS:
            raise UsdWorldError(f"shadow_taps must be one of {sorted(_SHADOW_FILTERS)}, got {shadow_taps}")
        self.shadow_taps = int(shadow_taps)
        self.cull_back_faces = bool(cull_back_faces)
        self.near_first = bool(near_first)
        #: batches whose back faces the last :meth:`render_rgb` culled, of all (for benchmarks)
        self.last_culled: tuple[int, int] | None = None
        self.width, self.height = int(width), int(height)
        self.occlusion_cull = bool(occlusion_cull)
        self.rendering = rendering or RenderingParams()
        #: instances the last :meth:`render` drew in its label and colour passes, of all (for benchmarks)
        self.last_shown: tuple[int, int] | None = None
        #: the instances the last shadow map drew
        self.last_sunlit: int | None = None
        #: the instances the last :meth:`render` drew in its colour pass after the occlusion test
        #: (those of the objects that won a pixel in the labels); None: as in the label pass
        self.last_colored: int | None = None
        self.lighting = lighting or Lighting()
        self.near_m = float(near_m)
        self._ctx = create_context()
        ctx = self._ctx
        lit_fs = getattr(shaders, _SHADOW_FILTERS[self.shadow_taps])
        try:
            self._programs = {
                "shadow": ctx.program(vertex_shader=shaders.SHADOW_VS, fragment_shader=shaders.SHADOW_FS),
                "sky": ctx.program(vertex_shader=shaders.SKY_VS, fragment_shader=shaders.SKY_FS),
                "depth": ctx.program(vertex_shader=shaders.DEPTH_VS, fragment_shader=shaders.DEPTH_FS),
                "lit": ctx.program(vertex_shader=shaders.LIT_VS, fragment_shader=lit_fs),
                "lit_ambient": ctx.program(vertex_shader=shaders.LIT_VS, fragment_shader=shaders.LIT_AMBIENT_FS),
                "label": ctx.program(vertex_shader=shaders.LABEL_VS, fragment_shader=shaders.LABEL_FS),
            }
            size = (self.width, self.height)
            self._make_shadow_target(self.lighting.shadow_map_size)
            # One depth buffer for both: render() draws the labels first and the colour pass
            # shades against their depth (it is the depth pre-pass's: the same positions).
            depth = ctx.depth_renderbuffer(size)
            self._color_fbo = ctx.framebuffer(
                color_attachments=[ctx.renderbuffer(size, 4, dtype="f1")], depth_attachment=depth
            )
            self._label_fbo = ctx.framebuffer(
                color_attachments=[
                    ctx.renderbuffer(size, 1, dtype="i4"),
                    ctx.renderbuffer(size, 1, dtype="i4"),
                    ctx.renderbuffer(size, 1, dtype="i4"),
                    ctx.renderbuffer(size, 1, dtype="f4"),
                ],
                depth_attachment=depth,
            )
            self._sky_vao = ctx.vertex_array(self._programs["sky"], [])
        except Exception as exc:
            ctx.release()
            raise RenderError(f"OpenGL setup failed: {' '.join(str(exc).split())}") from exc
        self._buffers: _SceneBuffers | None = None
        self._shadow_key: tuple[int, bytes] | None = None
        self._path_shadow: tuple[RenderScene, PathShadow] | None = None

    # -- lifetime -------------------------------------------------------------------

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the GL context and everything on it (idempotent)."""
        if self._ctx is None:
            return
        self._ctx.__enter__()  # release this context's objects, not those of the one current now
        if self._buffers is not None:
            self._buffers.release()
            self._buffers = None
        self._ctx.release()
        self._ctx = None

    @property
    def gl_renderer(self) -> str:
        """The OpenGL renderer string, e.g. ``llvmpipe (LLVM 15.0.6, 256 bits)``."""
        return str(self._context().info["GL_RENDERER"])

    # -- public passes ----------------------------------------------------------------

    def render(self, scene: RenderScene, K: np.ndarray, world_from_cam: np.ndarray) -> RenderResult:
        """Colour, ids and depth of ``scene`` seen by an OpenCV pinhole camera.

        Args:
            scene: what to draw.
            K: (3, 3) float64 camera matrix for this renderer's width x height.
            world_from_cam: (4, 4) float64 pose, OpenCV camera -> world (Z up, metres).
        """
        K, world_from_cam = self._check_camera(K, world_from_cam)
        buffers = self._upload(scene)
        dense = scene.n_triangles >= self.rendering.occlusion_min_triangles_per_px * self.width * self.height
        shown = self._unhidden(scene, buffers, K, world_from_cam) if self.occlusion_cull and dense else None
        for b, mask in zip(buffers.batches, shown or [None] * len(buffers.batches)):
            b.show(mask)
        batches = buffers.batches
        self.last_shown = (sum(b.n_shown for b in batches), sum(b.n_instances for b in batches))
        self.last_colored = None
        # the occluders' depth stays for the labels (only where no surface can reach the far plane)
        kept = shown is not None and self._below_far(scene, world_from_cam)
        labels = self._labels(scene, K, world_from_cam, occluders_drawn=kept)
        class_ids, instance_ids, object_ids, depth = labels
        if shown is not None:
            # The colour pass draws, of the objects' instances, only those of objects that won a
            # pixel: at each pixel it shows the first fragment at the nearest depth, as the labels
            # do, whose object is one of them; another fragment there could only be drawn over.
            for b, mask in zip(batches, _of_objects_seen(object_ids, shown, batches), strict=True):
                b.show(mask)
            self.last_colored = sum(b.n_shown for b in batches)
        # The labels' depth buffer is the colour pass's depth pre-pass (the same "<" test on the
        # same positions, gl_Position being invariant in both programs): it is not drawn again.
        rgb = self._color_pass(scene, K, world_from_cam, depth_drawn=True)
        return RenderResult(rgb, class_ids, instance_ids, object_ids, depth)

    def render_rgb(self, scene: RenderScene, K: np.ndarray, world_from_cam: np.ndarray) -> np.ndarray:
        """(H, W, 3) uint8 lit colour with shadows and sky (same arguments as :meth:`render`)."""
        if not self.near_first:  # near first, the lit pass shows every instance in its own order
            self._show_all(scene)
        return self._color_pass(scene, K, world_from_cam, depth_drawn=False)

    def render_rgba_rows(self, scene: RenderScene, K: np.ndarray, world_from_cam: np.ndarray) -> bytes:
        """:meth:`render_rgb`'s colour as GL reads it: (H * W * 4,) RGBA bytes (alpha 255), rows bottom first.

        For an encoder that flips the rows itself (:class:`~usdworld.render.video.Mp4Writer` with
        ``source="rgba_bottom_up"``): no RGBA to RGB packing, no flip and no copy here.
        """
        if not self.near_first:
            self._show_all(scene)
        return self._color_pass(scene, K, world_from_cam, depth_drawn=False, raw=True)

    def _culled_faces(
        self, buffers: _SceneBuffers, K: np.ndarray, world_from_cam: np.ndarray
    ) -> list[str | None]:
        """Per batch, the face its closed meshes drop in this view (``cull_back_faces``), or None.

        A batch is culled only when the camera is outside every instance's axis-aligned box
        widened by the near plane's reach (the farthest point of the near plane from the eye):
        then no ray starts inside a mesh or enters one through the near plane, and its first
        hit on a closed mesh is a face turned towards it.
        """
        fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
        u = np.array([-0.5 - cx, self.width - 0.5 - cx]) / fx
        v = np.array([-0.5 - cy, self.height - 0.5 - cy]) / fy
        reach = self.near_m * float(np.sqrt(1.0 + np.max(u**2) + np.max(v**2)))
        eye = world_from_cam[:3, 3]
        out: list[str | None] = []
        for b in buffers.batches:
            face = b.cull_face()
            if face is not None:
                boxes = b.boxes_world()
                inside = np.all((boxes[:, 0] - reach <= eye) & (eye <= boxes[:, 1] + reach), axis=1)
                face = None if inside.any() else face
            out.append(face)
        self.last_culled = (sum(f is not None for f in out), len(out))
        return out

    def _show_all(self, scene: RenderScene) -> None:
        for b in self._upload(scene).batches:
            b.show(None)

    def _unhidden(
        self, scene: RenderScene, buffers: _SceneBuffers, K: np.ndarray, world_from_cam: np.ndarray
    ) -> list[np.ndarray] | None:
        """Per batch, (N,) bool the instances not hidden behind the occluders; None: no occluder.

        Draws the occluders' depth (the depth program, into the shared depth buffer) and tests
        every instance's box against it (:mod:`usdworld.render.occlusion`).
        """
        view_proj = self._view_proj(scene, K, world_from_cam)
        # every batch's boxes in one set of array operations (per batch, the numpy calls'
        # overhead outweighed their work: 57 batches at 10,000 objects); the same values per box
        corners, triangles = buffers.instance_boxes()
        size = (self.width, self.height)
        rect, depth, front = project_boxes(corners, view_proj, *size, self.near_m)
        per_triangle = self.rendering.occluder_px_per_triangle
        occ = occluders(rect, front, triangles, per_triangle, size[0] * size[1])
        if not occ.any():
            return None
        split = buffers.instance_splits()
        ctx = self._context()
        for b, shown in zip(buffers.batches, np.split(occ, split), strict=True):
            b.show(shown)
        self._color_fbo.use()
        self._color_fbo.color_mask = (False, False, False, False)
        self._color_fbo.clear(depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        _write(self._programs["depth"], "u_view_proj", view_proj)
        buffers.draw(ctx, "depth")
        self._color_fbo.color_mask = (True, True, True, True)
        raw = self._color_fbo.read(components=1, attachment=-1, dtype="f4", alignment=1)
        ctx.finish()
        pyramid = DepthPyramid(np.frombuffer(raw, dtype=np.float32).reshape(self.height, self.width)[::-1])
        return np.split(~hidden(rect, depth, front, pyramid), split)

    def _color_pass(
        self,
        scene: RenderScene,
        K: np.ndarray,
        world_from_cam: np.ndarray,
        depth_drawn: bool,
        raw: bool = False,
    ) -> Any:
        """The colour ((H, W, 3) uint8; ``raw``: GL's RGBA bytes, rows bottom first); ``depth_drawn``:
        the depth buffer holds this view's depth (from the labels)."""
        ctx = self._context()
        K, world_from_cam = self._check_camera(K, world_from_cam)
        buffers = self._upload(scene)
        view_proj = self._view_proj(scene, K, world_from_cam)
        # A sun of no light (an overcast world) adds exactly 0: no shadow map, no sun terms.
        sunlit = _sunlit(self.lighting)
        sun_vp, texel = self._shadow_pass(scene, buffers, K, world_from_cam) if sunlit else (np.eye(4), 0.0)
        pass_name = "lit" if sunlit else "lit_ambient"
        # render() shades against the label pass's depth, which culls nothing: no culling there
        culled = None
        if self.cull_back_faces and not depth_drawn:
            culled = self._culled_faces(buffers, K, world_from_cam)
        buffers.culled = culled

        self._color_fbo.use()
        self._color_fbo.depth_mask = not depth_drawn  # a clear with the mask off keeps the depth
        self._color_fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        self._color_fbo.depth_mask = True
        lt = self.lighting
        ctx.enable(ctx.DEPTH_TEST)
        if buffers.n_vertices:
            lit = self._programs[pass_name]
            _write(lit, "u_view_proj", view_proj)
            _write(lit, "u_sun_vp", sun_vp)
            _write(lit, "u_sun_dir", lt.sun_direction_world)
            _write(lit, "u_sun_color", lt.sun_color)
            _write(lit, "u_sky_ambient", lt.sky_ambient)
            _write(lit, "u_ground_ambient", lt.ground_ambient)
            _write(lit, "u_eye", world_from_cam[:3, 3])
            _write(lit, "u_specular", float(lt.specular))
            _write(lit, "u_shininess", float(lt.shininess))
            _write(lit, "u_inv_gamma", 1.0 / lt.gamma)
            _write(lit, "u_normal_offset", 1.5 * texel)
            _write(lit, "u_map_size", float(self._shadow_size))
            _write(lit, "u_shadow_map", 0)
            self._shadow_tex.use(location=0)
            buffers.last_order = None
            if self.near_first and not depth_drawn:
                # No pre-pass: near surfaces first, and the lit pass writes the depth.
                ctx.depth_func = "<="
                buffers.draw_near_first(ctx, pass_name, world_from_cam[:3, 3])
            else:
                # Depth first, then shade only the fragment that is seen (no shading of hidden ones).
                if not depth_drawn:
                    _write(self._programs["depth"], "u_view_proj", view_proj)
                    self._color_fbo.color_mask = (False, False, False, False)
                    buffers.draw(ctx, "depth")
                    self._color_fbo.color_mask = (True, True, True, True)
                ctx.depth_func = "<="
                # The depth buffer already holds each pixel's nearest depth, and the fragments that
                # pass "<=" lie at it: the lit pass writes no depth (llvmpipe then skips the stores).
                self._color_fbo.depth_mask = False
                buffers.draw(ctx, pass_name)
                self._color_fbo.depth_mask = True
        buffers.culled = None
        # The sky last, at the far plane: it passes "<=" only where no surface was drawn (the
        # surfaces' depth is < 1: the pre-pass's "<" test against the cleared 1 writes no other).
        sky = self._programs["sky"]
        _write(sky, "u_world_from_px", world_from_cam[:3, :3] @ np.linalg.inv(K))
        _write(sky, "u_size", np.array([self.width, self.height], dtype=np.float64))
        _write(sky, "u_zenith", lt.sky_zenith_srgb)
        _write(sky, "u_horizon", lt.sky_horizon_srgb)
        ctx.depth_func = "<="
        self._color_fbo.depth_mask = False
        self._sky_vao.render(mode=ctx.TRIANGLES, vertices=3)
        self._color_fbo.depth_mask = True
        ctx.depth_func = "<"
        if raw:
            data = self._color_fbo.read(components=4, alignment=1)
            ctx.finish()
            return data
        data = self._color_fbo.read(components=3, alignment=1)
        ctx.finish()
        return np.frombuffer(data, dtype=np.uint8).reshape(self.height, self.width, 3)[::-1].copy()

    def render_labels(
        self, scene: RenderScene, K: np.ndarray, world_from_cam: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Class ids, instance ids, object ids ((H, W) int32 each) and depth ((H, W) float32, metres).

        Same arguments as :meth:`render`.
        """
        K, world_from_cam = self._check_camera(K, world_from_cam)
        self._show_all(scene)
        return self._labels(scene, K, world_from_cam)

    def _labels(
        self, scene: RenderScene, K: np.ndarray, world_from_cam: np.ndarray, occluders_drawn: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`render_labels` of the instances shown (checked camera).

        ``occluders_drawn``: the depth buffer holds the occluders' depth (:meth:`_unhidden`), which
        the pass keeps (see :meth:`render`).
        """
        ctx = self._context()
        buffers = self._upload(scene)
        self._label_fbo.use()
        self._label_fbo.depth_mask = not occluders_drawn  # a clear with the mask off keeps the depth
        self._label_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self._label_fbo.depth_mask = True
        if buffers.n_vertices:
            prog = self._programs["label"]
            _write(prog, "u_view_proj", self._view_proj(scene, K, world_from_cam))
            _write(prog, "u_view", gl_view(world_from_cam))
            ctx.enable(ctx.DEPTH_TEST)
            if occluders_drawn:
                ctx.depth_func = "<="
                buffers.draw(ctx, "label_last_first")
                ctx.depth_func = "<"
            else:
                buffers.draw(ctx, "label")
        out = []
        for i, dtype in enumerate(("i4", "i4", "i4", "f4")):
            raw = self._label_fbo.read(components=1, attachment=i, dtype=dtype, alignment=1)
            out.append(np.frombuffer(raw, dtype=dtype).reshape(self.height, self.width)[::-1].copy())
        ctx.finish()
        class_ids, instance_ids, object_ids, depth = out
        return class_ids, instance_ids, object_ids, depth

    def update_shadow_map(self, scene: RenderScene, K: np.ndarray, world_from_cam: np.ndarray) -> None:
        """Render the sun's shadow map for this scene and view now (colour renders reuse it).

        :meth:`render_rgb` does this by itself whenever the scene or the shadow box changes;
        call it to time the pass or to refresh the map explicitly. Same arguments as :meth:`render`.
        """
        K, world_from_cam = self._check_camera(K, world_from_cam)
        buffers = self._upload(scene)
        self._shadow_key = None
        self._shadow_pass(scene, buffers, K, world_from_cam)
        self._context().finish()

    def fix_shadow_box(
        self, scene: RenderScene, K: np.ndarray, poses_world_from_cam: np.ndarray
    ) -> PathShadow:
        """Use one shadow map for every view of a camera path over this (static) scene.

        The sun's box holds the box each view would get on its own, and the map is enlarged
        (up to the GL texture limit) so that its texels are no coarser than the first view's
        own (:func:`~usdworld.render.lighting.path_shadow`). The map is drawn at the next
        colour render and reused by every later one of ``scene`` from any pose, until another
        scene is rendered or this is called again. A shadow box that follows each view
        re-draws the map whenever the camera moves.

        Args:
            scene: the scene the path is rendered in; it must not change along the path
                (a RenderScene is immutable: movers mean another scene, which ends the fixed box).
            K: (3, 3) float64 camera matrix of the path's views.
            poses_world_from_cam: (N, 4, 4) float64 poses of the path, the reference view first.

        Returns:
            The box, map size and texel sizes used.
        """
        ctx = self._context()
        K = check_intrinsics(K)
        limit = int(ctx.info.get("GL_MAX_TEXTURE_SIZE", MAX_SIZE))
        bounds = scene.bounds_world()
        size = (self.width, self.height)
        shadow = path_shadow(self.lighting, bounds, K, poses_world_from_cam, *size, min(limit, MAX_SIZE))
        if float(np.max(shadow.texel_m / shadow.first_view_texel_m)) > 1.0 + 1e-9:
            log.info(
                "fly-through shadow map capped at %d texels: texels %.3f m, the first view alone has %.3f m",
                shadow.map_size,
                float(np.max(shadow.texel_m)),
                float(np.max(shadow.first_view_texel_m)),
            )
        if shadow.map_size != self._shadow_size:
            self._release_shadow_target()
            self._make_shadow_target(shadow.map_size)
        self._path_shadow = (scene, shadow)
        self._shadow_key = None
        return shadow

    # -- internals ----------------------------------------------------------------------

    def _make_shadow_target(self, size: int) -> None:
        ctx = self._context()
        self._shadow_tex = ctx.depth_texture((size, size))
        self._shadow_tex.compare_func = "<="
        self._shadow_tex.repeat_x = self._shadow_tex.repeat_y = False
        self._shadow_fbo = ctx.framebuffer(depth_attachment=self._shadow_tex)
        self._shadow_size = size

    def _release_shadow_target(self) -> None:
        self._shadow_fbo.release()
        self._shadow_tex.release()

    def _context(self) -> Any:
        """The GL context, made current: another Renderer made and closed since leaves none current."""
        if self._ctx is None:
            raise RenderError("this Renderer is closed; create a new one")
        self._ctx.__enter__()  # eglMakeCurrent (the matching exit would only restore the previous context)
        return self._ctx

    def _check_camera(self, K: np.ndarray, world_from_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        K = check_intrinsics(K)
        T = np.asarray(world_from_cam, dtype=np.float64)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise UsdWorldError(f"world_from_cam must be a finite 4x4 matrix, got shape {T.shape}")
        return K, T

    def _upload(self, scene: RenderScene) -> _SceneBuffers:
        if self._buffers is not None and self._buffers.scene is scene:
            return self._buffers
        old = self._buffers
        self._buffers = _SceneBuffers(self._context(), scene, self._programs)
        if old is not None:
            old.release()
        self._shadow_key = None
        return self._buffers

    def _reach(self, scene: RenderScene, world_from_cam: np.ndarray) -> tuple[float, float]:
        """The farthest distance of the scene's box from the camera and the far plane, metres."""
        lo, hi = scene.bounds_world()
        corners = np.array(
            [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        )
        reach = float(np.linalg.norm(corners - world_from_cam[:3, 3], axis=1).max())
        return reach, max(reach * 1.01 + 1.0, self.near_m * 10.0)

    def _view_proj(self, scene: RenderScene, K: np.ndarray, world_from_cam: np.ndarray) -> np.ndarray:
        far = self._reach(scene, world_from_cam)[1]
        return gl_projection(K, self.width, self.height, self.near_m, far) @ gl_view(world_from_cam)

    def _below_far(self, scene: RenderScene, world_from_cam: np.ndarray) -> bool:
        """Whether every surface's window depth lies :data:`FAR_MARGIN` below the far plane's 1.

        A surface at depth z along the axis (at most the box's farthest distance) has the window
        depth ``far (z - near) / (z (far - near))``; one that rounds to 1 would pass a "<=" test
        against a cleared buffer, where a "<" test rejects it.
        """
        reach, far = self._reach(scene, world_from_cam)
        z = max(reach, self.near_m)
        return self.near_m * (far - z) / (z * (far - self.near_m)) >= FAR_MARGIN

    def _shadow_pass(
        self, scene: RenderScene, buffers: _SceneBuffers, K: np.ndarray, world_from_cam: np.ndarray
    ) -> tuple[np.ndarray, float]:
        fixed = self._path_shadow
        if fixed is not None and fixed[0] is scene:
            sun_vp, texel = fixed[1].sun_vp, float(np.max(fixed[1].texel_m))
        else:
            if fixed is not None:  # another scene: back to a box that follows the view
                self._path_shadow = None
                if self._shadow_size != self.lighting.shadow_map_size:
                    self._release_shadow_target()
                    self._make_shadow_target(self.lighting.shadow_map_size)
                    self._shadow_key = None
            sun_vp, texel = sun_view_projection(
                self.lighting, scene.bounds_world(), K, world_from_cam, self.width, self.height
            )
        key = (id(scene), sun_vp.astype(np.float32).tobytes())
        if key != self._shadow_key and buffers.n_vertices:
            self._draw_shadow_map(buffers, sun_vp)
            self._shadow_key = key
        return sun_vp, texel

    def _draw_shadow_map(self, buffers: _SceneBuffers, sun_vp: np.ndarray) -> None:
        # instances beyond the sides of the sun's box make no fragment: left out (same map)
        margin = SUN_MARGIN_TEXELS * 2.0 / self._shadow_size
        for b in buffers.batches:
            b.show_to_sun(~outside_clip_sides(b.corners_world(), sun_vp, margin))
        self.last_sunlit = sum(b.n_sunlit for b in buffers.batches)
        ctx = self._context()
        self._shadow_fbo.use()  # each framebuffer keeps its own full-size viewport
        self._shadow_fbo.clear(depth=1.0)
        ctx.enable(ctx.DEPTH_TEST)
        _write(self._programs["shadow"], "u_sun_vp", sun_vp)
        buffers.draw(ctx, "shadow")
