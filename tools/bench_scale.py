"""Benchmark one large world: author, open, render and edit at 1,000 / 10,000 / 100,000 objects.

The world is what ``usdworld build`` writes, made bigger: a synthetic 2048x1024 street
frame (``usdworld.synth``, seed 3) is turned into a :class:`~usdworld.layout.model.WorldModel`
by the build's own ``build_model``; its placements and ground meshes are then tiled as
blocks, up to 2 km along the street (X) and in parallel rows beside it (Y), centred on
the source camera, until the model holds the number of objects asked for. The world
folder is written with the build's own :func:`~usdworld.authoring.world.write_world`.

Measured per size (medians over ``--runs`` interleaved runs; the floors in the same run):

* **author**: ``write_world`` in process (the whole folder: assets, ground, base, edits, root);
* **open**: ``Usd.Stage.Open`` of ``world.usda`` in a fresh process (time inside the
  process, wall and CPU), and of it the parse of the base layer alone (the root's last
  sublayer, ``layers/base.usda`` or ``layers/base.usdc``; ``Sdf.Layer.FindOrOpen``, a floor
  for anything that opens the world);
* **render**: in a fresh process, opening the stage, reading the render scene (culled to
  the view and its shadows, :class:`~usdworld.render.instancing.ViewCull`) and drawing all
  passes (colour, ids, depth) from ``/World/SourceCamera`` at the photo's size, and each
  part of it (the GL context's creation is left out). A world with its object index is
  opened as ``usdworld render`` does (:mod:`usdworld.render.view_stage`): "open" is the
  stage without the objects, "scene" composes the objects that may reach the view and reads
  them (older checkouts: the whole stage);
* **edit**: the whole ``usdworld edit W move NAME --by 0.5,0 --force`` command (wall and
  the child's CPU), and in a fresh process the editor's parts: opening the world
  (``WorldEditor``: parsing the layers, composing the ground) and the move (reading the
  object index, composing the object and its possible neighbours, the rules, the atomic save);
* floors: a process that imports ``pxr.Usd``; a bare ``usdworld --help``.

With ``--edit-rounds N``, a third table times the whole ``usdworld edit W move`` command alone,
N rounds per size, each round on a fresh copy of the authored world (the first edit), this
checkout and ``--reference`` back to back and the floor (``usdworld --help``) in the same
round: the minimum and the median of the wall and of the child's CPU, and the median
over the floor. Each checkout runs the command once before the rounds.

The tool first compiles the bytecode of this checkout's and the reference's ``usdworld``
package (``compileall``), as installing a package does: under ``PYTHONDONTWRITEBYTECODE=1``
a checkout whose ``.pyc`` files are stale would recompile those modules in every command.

Usage::

    python tools/bench_scale.py [--sizes 1000,10000,100000] [--runs 3] [--keep DIR] [--reference CHECKOUT]
        [--edit-rounds N]

With ``--reference``, a second table compares, one run each, in fresh processes, authoring,
opening the world, the editor's parts, the whole edit command (twice: the second finds what
the first left, e.g. the object index) and reading the (unculled) render scene at 1,000
objects with another checkout (e.g. the code before this benchmark's changes), and whether
both write the same bytes; figures are wall / CPU seconds. A third table renders each size (up
to ``--no-render-above``) with the other checkout and with this one, ``--render-runs``
alternating rounds in fresh processes, each on the world it authored (the same layers; the
object index in its own format): open, culled scene, draw and their sum,
wall / CPU seconds, the triangles and the instances the camera's passes drew (``Renderer.last_shown``;
all of them for a checkout without the occlusion test) and the shadow map drew (``Renderer.last_sunlit``;
all for older code), of all the scene's, and whether the objects were composed
for the view only (:mod:`usdworld.render.view_stage`); ``--no-against`` leaves out the second
table (with ``--no-measure``: the render table alone).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: Street length the blocks are laid along (X), metres.
STREET_LENGTH_M = 2000.0
#: Gap between two blocks, metres.
BLOCK_GAP_M = 4.0

_RENDER_SNIPPET = r"""
import json, sys, time
t0 = time.perf_counter()
from pxr import Usd
from usdworld.render import Lighting, Renderer, RenderScene
from usdworld.render.instancing import ViewCull
from usdworld.render.outputs import view_camera, world_image_size
t1, c1 = time.perf_counter(), time.process_time()
try:  # a large world composed for the view (as `usdworld render`); older code: the whole stage
    from pathlib import Path
    from usdworld.parameters.authoring import AuthoringParams
    from usdworld.render.view_stage import open_outside, scene_for_view
    stage = open_outside(Path(sys.argv[1]), AuthoringParams().large_world_min_objects)
except ImportError:
    stage = None
outside = stage is not None
stage = stage or Usd.Stage.Open(sys.argv[1])
t2, c2 = time.perf_counter(), time.process_time()
w, h = world_image_size(stage)
pose = view_camera(stage, w, h)
cull = ViewCull(pose.K, pose.world_from_cam, w, h, Lighting().sun_direction_world)
scene = scene_for_view(Path(sys.argv[1]), stage, cull) if outside else None
view = scene is not None
scene = scene or RenderScene.from_stage(stage if not outside else Usd.Stage.Open(sys.argv[1]), cull=cull)
t3, c3 = time.perf_counter(), time.process_time()
with Renderer(w, h) as r:
    t4, c4 = time.perf_counter(), time.process_time()
    r.render(scene, pose.K, pose.world_from_cam)
    t5, c5 = time.perf_counter(), time.process_time()
    shown = getattr(r, "last_shown", None)  # (instances drawn by the camera's passes, all); older code: None
    sunlit = getattr(r, "last_sunlit", None)  # instances the shadow map drew; older code: None (all)
print(json.dumps({"import": t1 - t0, "open": t2 - t1, "scene": t3 - t2, "context": t4 - t3, "draw": t5 - t4,
                  "render": (t3 - t1) + (t5 - t4), "open_cpu": c2 - c1, "scene_cpu": c3 - c2,
                  "draw_cpu": c5 - c4, "render_cpu": (c3 - c1) + (c5 - c4), "triangles": scene.n_triangles,
                  "instances": sum(b.n_instances for b in scene.batches),
                  "instances_shown": shown[0] if shown else sum(b.n_instances for b in scene.batches),
                  "instances_sunlit": sunlit if sunlit is not None else sum(b.n_instances for b in scene.batches),
                  "objects": len(scene.objects), "view_stage": view}))
"""

_OPEN_SNIPPET = r"""
import json, os, sys, time
from pxr import Sdf, Usd
top = Sdf.Layer.OpenAsAnonymous(sys.argv[1], metadataOnly=True)
base = os.path.normpath(os.path.join(os.path.dirname(sys.argv[1]), top.subLayerPaths[-1]))
t0, c0 = time.perf_counter(), time.process_time()
Sdf.Layer.FindOrOpen(base)
t1, c1 = time.perf_counter(), time.process_time()
stage = Usd.Stage.Open(sys.argv[1])
t2, c2 = time.perf_counter(), time.process_time()
print(json.dumps({"open": t2 - t0, "parse_base": t1 - t0, "open_cpu": c2 - c0, "parse_base_cpu": c1 - c0}))
"""


_EDIT_SNIPPET = r"""
import json, sys, time
from usdworld.authoring.edits import WorldEditor
t0, c0 = time.perf_counter(), time.process_time()
editor = WorldEditor(sys.argv[1])
t1, c1 = time.perf_counter(), time.process_time()
editor.move(sys.argv[2], by=(0.5, 0.0), force=True)
t2, c2 = time.perf_counter(), time.process_time()
print(json.dumps({"edit_open": t1 - t0, "edit_move": t2 - t1, "edit_open_cpu": c1 - c0, "edit_move_cpu": c2 - c1}))
"""


_AUTHOR_SNIPPET = r"""
import json, pickle, sys, time
from usdworld.authoring import asset_library
from usdworld.authoring.world import write_world
model = pickle.load(open(sys.argv[1], "rb"))
libraries = asset_library.library_dirs(None)
assets = {c: asset_library.asset_path(c, libraries) for c in sorted({p.obj.class_name for p in model.placements})}
t0, c0 = time.perf_counter(), time.process_time()
write_world(model, __import__("pathlib").Path(sys.argv[2]), assets, None)
print(json.dumps({"author": time.perf_counter() - t0, "author_cpu": time.process_time() - c0}))
"""

_SCENE_SNIPPET = r"""
import json, sys, time
from pxr import Usd
from usdworld.render import RenderScene
stage = Usd.Stage.Open(sys.argv[1])
t0 = time.perf_counter()
scene = RenderScene.from_stage(stage)
print(json.dumps({"scene": time.perf_counter() - t0, "triangles": scene.n_triangles}))
"""


def base_model(tmp: Path, seed: int, width: int, height: int):  # -> WorldModel
    """The model ``usdworld build`` makes of a synthetic frame."""
    from usdworld.authoring.asset_library import library_dirs
    from usdworld.pipeline import BuildRequest, build_model
    from usdworld.synth import make_street_scene, write_cityscapes_frame

    scene = make_street_scene(np.random.default_rng(seed), width, height)
    files = write_cityscapes_frame(scene, tmp / "in", "scale_000000_000001")
    request = BuildRequest(
        image=files["image"],
        labels=files["labels"],
        instances=files["instances"],
        camera=files["camera"],
        output=tmp / "unused",
    )
    return build_model(request, library_dirs(None))


def tiled_model(model, n_objects: int):  # (WorldModel, int) -> WorldModel
    """``model`` with its objects and ground tiled into blocks until it holds ``n_objects`` objects.

    Blocks follow each other along X up to :data:`STREET_LENGTH_M`, then start a new row
    beside the street (Y); the block holding the photo's own objects stays in place, so the
    source camera sees its street as in the photo, with the rest of the blocks around it.
    """
    from usdworld.layout.surfaces import SurfaceMesh

    ps = model.placements
    centres = np.array([p.position_world[:2] for p in ps])
    half = np.array([0.5 * float(np.max(p.size_m[:2])) for p in ps])[:, None]
    lo = np.min(centres - half, axis=0)
    hi = np.max(centres + half, axis=0)
    step = hi - lo + BLOCK_GAP_M
    blocks = math.ceil(n_objects / len(ps))
    nx = max(1, min(blocks, int(STREET_LENGTH_M // step[0])))
    ny = math.ceil(blocks / nx)
    offsets = [
        np.array([(i - nx // 2) * step[0], (j - ny // 2) * step[1], 0.0])
        for j in range(ny)
        for i in range(nx)
    ][:blocks]
    counts: dict[str, int] = {}
    placements = []
    for off in offsets:
        for p in ps:
            if len(placements) == n_objects:
                break
            k = counts.get(p.obj.class_name, 0) + 1
            counts[p.obj.class_name] = k
            placements.append(
                dataclasses.replace(
                    p, name=f"{p.obj.class_name}_{k:04d}", position_world=p.position_world + off
                )
            )
    surfaces = []
    for s in model.surfaces:
        n = len(s.points_world)
        surfaces.append(
            SurfaceMesh(
                s.name,
                np.concatenate([s.points_world + off for off in offsets]),
                np.concatenate([s.faces + k * n for k in range(len(offsets))]),
                s.area_m2 * len(offsets),
            )
        )
    return dataclasses.replace(model, placements=tuple(placements), surfaces=tuple(surfaces))


_HERE = Path(__file__).resolve().parents[1]


def _env(repo: Path = _HERE, bytecode: bool = False) -> dict[str, str]:
    env = {**os.environ, "PYTHONPATH": str(repo) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    if bytecode:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(cmd: list[str], repo: Path = _HERE) -> tuple[float, float, str]:
    """Run a command in a fresh process: (wall s, its CPU s, its stdout)."""
    c0, t0 = _children_cpu(), time.perf_counter()
    # run in the checkout: ``python -c`` and ``-m`` put the working folder first on sys.path
    done = subprocess.run(cmd, capture_output=True, text=True, env=_env(repo), cwd=repo, check=False)
    wall, cpu = time.perf_counter() - t0, _children_cpu() - c0
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()[-2000:]}")
    return wall, cpu, done.stdout


def edit_rounds(
    model, n: int, folder: Path, rounds: int, repos: dict[str, Path]
) -> dict[str, list[tuple[float, float]]]:
    """The whole ``usdworld edit W move`` command, ``rounds`` times per checkout, and the floor.

    Each round runs every checkout on a fresh copy of the world it authored itself from the
    same model (its object index is in that checkout's format; a world another checkout
    wrote would make it read the layer again), so each command is the world's first edit;
    then ``usdworld --help``.

    Returns:
        checkout tag (and ``floor``) -> (wall s, CPU s) per round.
    """
    import pickle

    mover = next(p.name for p in model.placements if p.obj.class_name == "car")
    pkl = folder / f"edit_model_{n}.pkl"
    pkl.write_bytes(pickle.dumps(model))
    sources = {tag: folder / f"edit_source_{tag}_{n}" for tag in repos}
    for tag, repo in repos.items():
        _snippet(_AUTHOR_SNIPPET, pkl, sources[tag], repo=repo)

    def edit(tag: str, repo: Path, bytecode: bool = False) -> tuple[float, float]:
        world = folder / f"edit_{tag}_{n}"
        shutil.rmtree(world, ignore_errors=True)
        shutil.copytree(sources[tag], world)
        cmd = [sys.executable, "-m", "usdworld", "edit", str(world), "move", mover, "--by", "0.5,0"]
        cmd.append("--force")
        c0, t0 = _children_cpu(), time.perf_counter()
        env = _env(repo, bytecode)
        done = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=repo, check=False)
        wall, cpu = time.perf_counter() - t0, _children_cpu() - c0
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()[-2000:]}")
        shutil.rmtree(world)
        return wall, cpu

    for tag, repo in repos.items():  # compile the checkouts' bytecode once, outside the rounds
        edit(tag, repo, bytecode=True)
        help_cmd = [sys.executable, "-m", "usdworld", "--help"]
        subprocess.run(help_cmd, capture_output=True, env=_env(repo, True), cwd=repo, check=False)
    out: dict[str, list[tuple[float, float]]] = {tag: [] for tag in [*repos, "floor"]}
    for _ in range(rounds):
        for tag, repo in repos.items():
            out[tag].append(edit(tag, repo))
        wall, cpu, _ = _timed([sys.executable, "-m", "usdworld", "--help"])
        out["floor"].append((wall, cpu))
    for source in sources.values():
        shutil.rmtree(source)
    pkl.unlink()
    return out


def _wall(cmd: list[str], repo: Path = _HERE) -> tuple[float, str]:
    wall, _, out = _timed(cmd, repo)
    return wall, out


def base_layer(world: Path) -> Path:
    """A world's base layer file: its root's last sublayer."""
    from pxr import Sdf

    root = Sdf.Layer.OpenAsAnonymous(str(world / "world.usda"), metadataOnly=True)
    return Path(os.path.normpath(world / root.subLayerPaths[-1]))


def _snippet(code: str, *args: object, repo: Path = _HERE) -> dict:
    _, out = _wall([sys.executable, "-c", code, *map(str, args)], repo)
    return json.loads(out.strip().splitlines()[-1])


def _median(rows: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in rows)


def measure(model, n: int, folder: Path, runs: int, render: bool) -> dict:
    """All figures for one size (see the module docstring)."""
    from usdworld.authoring import asset_library
    from usdworld.authoring.world import write_world

    libraries = asset_library.library_dirs(None)
    classes = sorted({p.obj.class_name for p in model.placements})
    assets = {c: asset_library.asset_path(c, libraries) for c in classes}
    mover = next(p.name for p in model.placements if p.obj.class_name == "car")
    rows: list[dict] = []
    for run in range(runs):
        world = folder / f"world_{n}_{run}"
        t0, c0 = time.perf_counter(), time.process_time()
        write_world(model, world, assets, None)
        row = {"author": time.perf_counter() - t0, "author_cpu": time.process_time() - c0}
        row["floor_import"], _ = _wall([sys.executable, "-c", "import pxr.Usd"])
        row.update(_snippet(_OPEN_SNIPPET, world / "world.usda"))
        row["floor_help"], _ = _wall([sys.executable, "-m", "usdworld", "--help"])
        if render:
            row.update({f"render_{k}": v for k, v in _snippet(_RENDER_SNIPPET, world / "world.usda").items()})
        row.update(_snippet(_EDIT_SNIPPET, world / "world.usda", mover))
        row["edit"], row["edit_cpu"], _ = _timed(
            [sys.executable, "-m", "usdworld", "edit", str(world), "move", mover, "--by", "0.5,0", "--force"]
        )
        rows.append(row)
        if run:
            shutil.rmtree(world)
    out = {key: _median(rows, key) for key in rows[0]}
    out["objects"] = n
    out["bytes_base"] = base_layer(folder / f"world_{n}_0").stat().st_size
    return out


def against(model, n: int, folder: Path, reference: Path, scene: bool) -> dict:
    """Author, open, the editor's parts, the whole edit command (twice) and (when ``scene``)
    reading the unculled render scene, each in fresh processes with ``reference`` and then
    with this checkout; ``*_cpu`` keys hold the CPU seconds of the same figure."""
    import pickle

    pkl = folder / f"model_{n}.pkl"
    pkl.write_bytes(pickle.dumps(model))
    mover = next(p.name for p in model.placements if p.obj.class_name == "car")
    repos = {"ref": reference, "new": _HERE}
    out: dict = {}
    for tag, repo in repos.items():
        r = _snippet(_AUTHOR_SNIPPET, pkl, folder / f"ab_{tag}_{n}", repo=repo)
        out[f"author_{tag}"], out[f"author_cpu_{tag}"] = r["author"], r.get("author_cpu", float("nan"))
    diff = subprocess.run(
        ["diff", "-rq", folder / f"ab_ref_{n}", folder / f"ab_new_{n}"], capture_output=True, check=False
    )
    out["same_bytes"] = diff.returncode == 0
    for tag, repo in repos.items():
        world = folder / f"ab_{tag}_{n}"
        out[f"base_bytes_{tag}"] = base_layer(world).stat().st_size
        r = _snippet(_OPEN_SNIPPET, world / "world.usda", repo=repo)
        for key in ("open", "open_cpu", "parse_base", "parse_base_cpu"):
            out[f"{key}_{tag}"] = r[key]
        if scene:
            out[f"scene_{tag}"] = _snippet(_SCENE_SNIPPET, world / "world.usda", repo=repo)["scene"]
        r = _snippet(_EDIT_SNIPPET, world / "world.usda", mover, repo=repo)
        for key in ("edit_open", "edit_open_cpu", "edit_move", "edit_move_cpu"):
            out[f"{key}_{tag}"] = r[key]
        move = ["edit", str(world), "move", mover, "--by", "0.5,0", "--force"]
        out[f"edit_{tag}"], out[f"edit_cpu_{tag}"], _ = _timed([sys.executable, "-m", "usdworld", *move], repo)
        out[f"edit2_{tag}"], out[f"edit2_cpu_{tag}"], _ = _timed([sys.executable, "-m", "usdworld", *move], repo)
        shutil.rmtree(world)
    pkl.unlink()
    return out


def render_against(model, n: int, folder: Path, reference: Path, runs: int) -> list[tuple[str, dict]]:
    """The render snippet (open, culled scene, all passes from the source camera) with ``reference``
    and with this checkout, alternating, ``runs`` rounds, in fresh processes; each checkout renders
    the world it authors itself (the same layers; the object index is in each one's format)."""
    import pickle

    pkl = folder / f"model_{n}.pkl"
    pkl.write_bytes(pickle.dumps(model))
    repos = {"ref": reference, "new": _HERE}
    worlds = {tag: folder / f"render_{tag}_{n}" for tag in repos}
    for tag, repo in repos.items():
        _snippet(_AUTHOR_SNIPPET, pkl, worlds[tag], repo=repo)
    pkl.unlink()
    rows = []
    for run in range(runs):
        order = ("ref", "new") if run % 2 == 0 else ("new", "ref")
        for tag in order:
            rows.append((tag, _snippet(_RENDER_SNIPPET, worlds[tag] / "world.usda", repo=repos[tag])))
    for world in worlds.values():
        shutil.rmtree(world)
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1000,10000,100000")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--no-render-above", type=int, default=10**9, help="skip the render above this size")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--keep", type=Path, help="keep the worlds in this folder")
    parser.add_argument(
        "--no-measure", action="store_true", help="only the before/after table (with --reference)"
    )
    parser.add_argument(
        "--edit-rounds",
        type=int,
        default=0,
        help="also time the whole edit command this many rounds per size (with --reference: both checkouts)",
    )
    parser.add_argument(
        "--no-against", action="store_true", help="with --reference: only the before/after render table"
    )
    parser.add_argument(
        "--render-runs", type=int, default=2, help="rounds of the before/after render (with --reference)"
    )
    parser.add_argument(
        "--reference",
        type=Path,
        help="also author, edit and read the scene with this checkout (before/after)",
    )
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]
    for repo in (_HERE, *(() if args.reference is None else (args.reference,))):
        # As an installed package: compiled once, so no timed command compiles stale modules
        # (this environment sets PYTHONDONTWRITEBYTECODE=1).
        compile_cmd = [sys.executable, "-m", "compileall", "-q", str(repo / "usdworld")]
        subprocess.run(compile_cmd, capture_output=True, check=False)
    tmp = Path(tempfile.mkdtemp(prefix="bench_scale_"))
    folder = args.keep or tmp
    try:
        model = base_model(tmp, args.seed, 2048, 1024)
        print(
            f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.node()}, "
            f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at start; "
            f"base frame: {len(model.placements)} objects"
        )
        floors = {
            "import pxr": _timed([sys.executable, "-c", "import pxr.Usd"]),
            "usdworld --help": _timed([sys.executable, "-m", "usdworld", "--help"]),
        }
        print("floors (wall / CPU s): " + ", ".join(f"{k} {w:.2f} / {c:.2f}" for k, (w, c, _) in floors.items()))
        if not args.no_measure:
            print(
                "| objects | author s wall / CPU | open s wall / CPU (parse base layer) | render s (open + scene + draw) "
                "| render CPU s (open + scene + draw) | triangles drawn | instances drawn (camera / shadow) "
                "| edit move s wall / CPU (whole) | edit parts s wall / CPU "
                "(open + move) | floor: import pxr s | floor: usdworld --help s | edit own cost s "
                "| base layer MB | load |"
            )
            print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for n in sizes if not args.no_measure else ():
            r = measure(
                tiled_model(model, n), n, folder, args.runs if n < 100_000 else 1, n <= args.no_render_above
            )
            render = (
                f"{r['render_render']:.3f} ({r['render_open']:.3f} + {r['render_scene']:.3f} + "
                f"{r['render_draw']:.3f})"
                if "render_render" in r
                else "not measured"
            )
            draw = (
                f"{r['render_render_cpu']:.3f} ({r['render_open_cpu']:.3f} + {r['render_scene_cpu']:.3f} + "
                f"{r['render_draw_cpu']:.3f})"
                if "render_render" in r
                else "-"
            )
            tris = f"{r['render_triangles']:,.0f}" if "render_triangles" in r else "-"
            shown = "-"
            if "render_render" in r:
                shown = f"{r['render_instances_shown']:,.0f} / {r['render_instances']:,.0f}"
            print(
                f"| {n:,d} | {r['author']:.2f} / {r['author_cpu']:.2f} | {r['open']:.3f} / {r['open_cpu']:.3f} ({r['parse_base']:.3f} / "
                f"{r['parse_base_cpu']:.3f}) | {render} | {draw} | {tris} | {shown} | {r['edit']:.2f} / {r['edit_cpu']:.2f} "
                f"| {r['edit_open']:.2f} / {r['edit_open_cpu']:.2f} + {r['edit_move']:.2f} / {r['edit_move_cpu']:.2f} "
                f"| {r['floor_import']:.2f} | {r['floor_help']:.2f} | {r['edit'] - r['floor_help']:.2f} "
                f"| {r['bytes_base'] / 1e6:.1f} | {os.getloadavg()[0]:.2f} |",
                flush=True,
            )
        if args.reference is not None:
            print(f"\nbefore/after ({args.reference} / this checkout), wall / CPU s, load average {os.getloadavg()[0]:.2f}")
            print(
                "| objects | | author | base layer MB | open (parse base layer) | edit: WorldEditor | edit: move "
                "| edit move, whole | again | read render scene (wall) | same bytes | load |"
            )
            print("|---|---|---|---|---|---|---|---|---|---|---|---|")
            for n in sizes if not args.no_against else ():
                r = against(tiled_model(model, n), n, folder, args.reference, n <= 1000)
                for tag, what in (("ref", "before"), ("new", "after")):

                    def f(key: str, tag: str = tag) -> str:
                        return f"{r[f'{key}_{tag}']:.2f} / {r[f'{key}_cpu_{tag}']:.2f}"

                    scene = f"{r[f'scene_{tag}']:.2f}" if f"scene_{tag}" in r else "-"
                    print(
                        f"| {n:,d} | {what} | {f('author')} | {r[f'base_bytes_{tag}'] / 1e6:.2f} "
                        f"| {f('open')} ({f('parse_base')}) | {f('edit_open')} | {f('edit_move')} | {f('edit')} "
                        f"| {f('edit2')} | {scene} | {r['same_bytes']} | {os.getloadavg()[0]:.2f} |",
                        flush=True,
                    )
            render_sizes = [n for n in sizes if n <= args.no_render_above]
            if render_sizes and args.render_runs > 0:
                print(
                    f"\nrender from the source camera, before/after ({args.reference} / this checkout), "
                    f"{args.render_runs} alternating rounds, fresh processes; wall / CPU s"
                )
                print(
                    "| objects | | open | scene | draw | render (open + scene + draw) | triangles "
                    "| instances drawn (camera / shadow map, of all) | objects composed for the view only | load |"
                )
                print("|---|---|---|---|---|---|---|---|---|---|")
                for n in render_sizes:
                    rows = render_against(tiled_model(model, n), n, folder, args.reference, args.render_runs)
                    for tag, r in rows:

                        def g(key: str, r: dict = r) -> str:
                            cpu = f"{r[key + '_cpu']:.3f}" if key + "_cpu" in r else "-"
                            return f"{r[key]:.3f} / {cpu}"

                        every = r.get("instances", 0)
                        sunlit = r.get("instances_sunlit", every)
                        shown = f"{r.get('instances_shown', every):,} / {sunlit:,} of {every:,}"
                        print(
                            f"| {n:,d} | {'before' if tag == 'ref' else 'after'} | {g('open')} | {g('scene')} "
                            f"| {g('draw')} | {g('render')} | {r['triangles']:,} | {shown} "
                            f"| {'yes' if r.get('view_stage') else 'no'} | {os.getloadavg()[0]:.2f} |",
                            flush=True,
                        )
        if args.edit_rounds:
            repos = {"this checkout": _HERE}
            if args.reference is not None:
                repos = {f"reference {args.reference}": args.reference, **repos}
            print(
                f"\nwhole `usdworld edit W move`, {args.edit_rounds} rounds (fresh world copy each), "
                f"load average {os.getloadavg()[0]:.2f}"
            )
            print("| objects | checkout | wall s min / median | CPU s min / median | median over the floor s | load |")
            print("|---|---|---|---|---|---|")
            for n in sizes:
                timed = edit_rounds(tiled_model(model, n), n, folder, args.edit_rounds, repos)
                floor = statistics.median(w for w, _ in timed["floor"])
                for tag, rows in timed.items():
                    walls, cpus = [w for w, _ in rows], [c for _, c in rows]
                    over = "-" if tag == "floor" else f"{statistics.median(walls) - floor:.3f}"
                    name = "floor: usdworld --help" if tag == "floor" else tag
                    print(
                        f"| {n:,d} | {name} | {min(walls):.3f} / {statistics.median(walls):.3f} "
                        f"| {min(cpus):.3f} / {statistics.median(cpus):.3f} | {over} | {os.getloadavg()[0]:.2f} |",
                        flush=True,
                    )
    finally:
        if args.keep is None:
            shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
