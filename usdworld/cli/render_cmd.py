"""``usdworld render``: every pass of one view of a world, written as images."""

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
        None, "--photo", help="The source photo (default: found next to the world)."
    ),
) -> None:
    """Render a world: colour, class, instance and depth images (+ a comparison with the photo)."""
    import logging
    import time

    from usdworld.authoring.inspect import open_world
    from usdworld.demo import demo_dir
    from usdworld.errors import OutputError
    from usdworld.render import Renderer, RenderScene
    from usdworld.render.outputs import (
        find_beside_world,
        read_photo,
        view_camera,
        world_image_size,
        world_source_image,
        write_render_outputs,
    )

    log = logging.getLogger("usdworld.render")
    if output.exists() and not output.is_dir():
        raise OutputError(f"{output}: exists and is not a folder; choose another -o")
    from usdworld.authoring.rig import rig_view

    stage = open_world(world)
    camera, view_photo = rig_view(stage, camera)
    width, height = parse_size(size) if size else world_image_size(stage)
    pose = view_camera(stage, width, height, camera)
    photo_path = photo
    if photo_path is None:
        root = Path(stage.GetRootLayer().realPath)
        photo_name = view_photo or world_source_image(stage)
        photo_path = find_beside_world(root, photo_name, [demo_dir()])
        if photo_path is None:
            log.info(
                "source photo %r not found next to the world; pass --photo for the comparison images",
                photo_name or "(none recorded)",
            )
    photo_rgb = read_photo(photo_path) if photo_path is not None else None
    t0 = time.perf_counter()
    scene = RenderScene.from_stage(stage)
    with Renderer(width, height) as renderer:
        result = renderer.render(scene, pose.K, pose.world_from_cam)
    seconds = time.perf_counter() - t0
    paths = write_render_outputs(output, result, photo_rgb)
    from usdworld.cli.output import quiet

    if quiet():
        return
    for path in paths.values():
        typer.echo(str(path))
    typer.echo(
        f"rendered {width}x{height} from {camera or '/World/SourceCamera'}: {scene.n_triangles:,d} triangles, "
        f"{len(scene.objects)} objects in {seconds:.2f} s"
    )


def register(app: typer.Typer) -> None:
    """Add the command to the app."""
    app.command("render")(render)
