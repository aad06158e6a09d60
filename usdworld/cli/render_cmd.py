"""``usdworld render``: the passes of one view of a world, written as the image files asked for."""

from __future__ import annotations

from pathlib import Path

import typer


def parse_size(text: str, option: str = "--size") -> tuple[int, int]:
    """``"960x480"`` -> (960, 480); raises InputError for anything else."""
    from usdworld.errors import InputError

    parts = text.lower().replace(" ", "").split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise InputError(f"{option} {text!r}: expected WIDTHxHEIGHT in pixels, e.g. 1024x512") from None
    if not (0 < w <= 8192 and 0 < h <= 8192):
        raise InputError(f"{option} {text!r}: width and height must be 1..8192 pixels")
    return w, h


def render(
    world: Path = typer.Argument(..., help="A world's world.usda (or its folder)."),
    output: Path = typer.Option(..., "--output", "-o", help="Folder for the images (created if missing)."),
    size: str | None = typer.Option(None, "--size", help="WIDTHxHEIGHT; default the source image's size."),
    camera: str | None = typer.Option(
        None,
        "--camera",
        help="Camera prim path, or a view's name in a multi-view world (/World/Cameras/NAME); "
        "default /World/SourceCamera.",
    ),
    photo: Path | None = typer.Option(
        None, "--photo", help="The source photo for the comparisons (default: found next to the world)."
    ),
    at_time: str | None = typer.Option(
        None,
        "--time",
        help="A drive's world at this time: a time code (3) or seconds from its first frame (1.5s); "
        "moving objects at their time-sampled places, shown only where they were seen, and "
        "/World/Ego/Camera where the ego was. Default: the default time (every object at its first place).",
    ),
    write: str = typer.Option(
        "data",
        "--write",
        help="Comma-separated outputs: data (render.png, labelIds.png, instanceIds.png, depth.npy), "
        "views (class.png, instance.png, depth.png), comparisons (side_by_side.png, overlay.png; need the "
        "photo), all, or single ones: render, labelIds, instanceIds, depth, class, instance, depth_png, "
        "side_by_side, overlay.",
    ),
) -> None:
    """Render a world's passes as image files: the data by default, colour views and photo comparisons on request."""
    import logging
    import time

    from usdworld.authoring.inspect import open_world
    from usdworld.errors import InputError, OutputError
    from usdworld.render import Renderer, ViewCull
    from usdworld.render.outputs import (
        COMPARISONS,
        find_beside_world,
        parse_outputs,
        read_photo,
        view_camera,
        world_image_size,
        world_source_image,
        write_render_outputs,
    )

    log = logging.getLogger("usdworld.render")
    outputs = parse_outputs(write)
    if output.exists() and not output.is_dir():
        raise OutputError(f"{output}: exists and is not a folder; choose another -o")
    from usdworld.authoring.rig import rig_view

    from usdworld.render.timing import parse_time, scene_at

    from usdworld.parameters.authoring import AuthoringParams
    from usdworld.render.view_stage import open_outside, scene_for_view
    from usdworld.world_files import ROOT_LAYER

    world_file = world / ROOT_LAYER if world.is_dir() else world
    # A large world with a kept object index is first composed without its objects; the
    # objects that may reach the view are composed once the camera is known (same pixels).
    outside = None
    if at_time is None and world_file.is_file():
        outside = open_outside(world_file, AuthoringParams().large_world_min_objects)
    stage = outside if outside is not None else open_world(world)
    code = parse_time(stage, at_time) if at_time is not None else None
    camera, view_photo = rig_view(stage, camera)
    if outside is not None and not stage.GetPrimAtPath(camera or "/World/SourceCamera"):
        outside = None  # a camera below the objects: the whole world
        stage = open_world(world)
    width, height = parse_size(size) if size else world_image_size(stage)
    pose = view_camera(stage, width, height, camera, code)
    comparisons = [name for name in outputs if name in COMPARISONS]
    if photo is not None and not photo.is_file():
        raise InputError(f"{photo}: no such photo; pass --photo with the source image")
    if photo is not None and not comparisons:
        log.info("--photo is used by the comparisons only (--write comparisons or all); not read")
    photo_path = photo
    if comparisons and photo_path is None:
        from usdworld.demo import demo_dir

        root = Path(stage.GetRootLayer().realPath)
        photo_name = view_photo or world_source_image(stage)
        photo_path = find_beside_world(root, photo_name, [demo_dir()])
        if photo_path is None:
            recorded = photo_name or "(none recorded)"
            named = {token.strip() for token in write.split(",")}
            if named & {"comparisons", *COMPARISONS}:  # asked for by name, not as part of "all"
                raise InputError(
                    f"--write {','.join(comparisons)}: the source photo {recorded!r} is not next to the world; "
                    "pass it with --photo"
                )
            log.info(
                "source photo %r not found next to the world; pass --photo for the comparison images",
                recorded,
            )
    photo_rgb = read_photo(photo_path) if comparisons and photo_path is not None else None
    t0 = time.perf_counter()
    # Objects whose boxes and shadows lie outside the view are not read (same pixels).
    from usdworld.render.world_lights import lighting_from_stage

    lighting = lighting_from_stage(stage)  # the world's own sun and sky (the default for an old world)
    cull = ViewCull(pose.K, pose.world_from_cam, width, height, lighting.sun_direction_world)
    scene = scene_for_view(world_file, outside, cull) if outside is not None else None
    if outside is not None:
        log.debug("objects composed for the view only: %s", "yes" if scene else "no, the whole world")
    if scene is None:
        if outside is not None:
            stage = open_world(world)
        scene = scene_at(stage, code, cull=cull)
    with Renderer(width, height, lighting=lighting) as renderer:
        result = renderer.render(scene, pose.K, pose.world_from_cam)
    seconds = time.perf_counter() - t0
    paths = write_render_outputs(output, result, photo_rgb, outputs)
    from usdworld.cli.output import quiet

    if quiet():
        return
    for path in paths.values():
        typer.echo(str(path))
    typer.echo(
        f"rendered {width}x{height} from {camera or '/World/SourceCamera'}"
        f"{'' if code is None else f' at time code {code:g}'}: {scene.n_triangles:,d} triangles, "
        f"{len(scene.objects)} objects in {seconds:.2f} s"
    )


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("render")(render)
