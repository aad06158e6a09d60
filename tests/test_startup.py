"""Start-up stays light: what importing usdworld and running the CLI's help load (timings: tools/bench_startup.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from usdworld.authoring import asset_library

REPO = Path(__file__).resolve().parents[1]


def _loaded_after(code: str, whole_names: bool = False) -> set[str]:
    """Module names loaded by a fresh interpreter that runs ``code``: top-level names, or
    dotted ones with ``whole_names``."""
    name = "m" if whole_names else "m.split('.')[0]"
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted({{{name} for m in sys.modules}})))"
    out = subprocess.run(
        [sys.executable, "-c", probe], cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True, text=True, check=True
    )
    return set(json.loads(out.stdout.splitlines()[-1]))


def test_import_usdworld_loads_neither_pxr_nor_numpy() -> None:
    loaded = _loaded_after("import usdworld")
    assert not loaded & {"pxr", "numpy"}


def test_help_loads_no_domain_library() -> None:
    code = "from usdworld.cli.main import main\nimport contextlib, io\nwith contextlib.redirect_stdout(io.StringIO()):\n    main(['--help'])"
    loaded = _loaded_after(code)
    assert not loaded & {"pxr", "numpy", "cv2", "scipy", "trimesh", "pydantic"}
    assert "rich" not in loaded  # plain help: typer's rich formatting costs a third of the start-up


def test_schemas_are_registered_by_the_authoring_package() -> None:
    code = (
        "import usdworld.authoring\nfrom pxr import Usd\n"
        "found = Usd.SchemaRegistry().FindAppliedAPIPrimDefinition('UsdWorldProvenanceAPI') is not None\n"
        "assert found, 'schema not registered'"
    )
    _loaded_after(code)  # raises CalledProcessError when the assertion fails


def test_mesh_arrays_match_the_trimesh_and_need_no_trimesh() -> None:
    mesh = asset_library.load_mesh("car")
    arrays = asset_library.load_mesh_arrays("car")
    np.testing.assert_array_equal(arrays.vertices, mesh.vertices)
    np.testing.assert_array_equal(arrays.faces, mesh.faces)
    np.testing.assert_array_equal(arrays.face_colors, mesh.visual.face_colors)
    np.testing.assert_array_equal(arrays.bounds, mesh.bounds)
    assert not arrays.vertices.flags.writeable  # the cached arrays are shared
    loaded = _loaded_after("from usdworld.authoring.asset_library import load_mesh_arrays\nload_mesh_arrays('car')")
    assert "trimesh" not in loaded


def test_a_named_sub_command_builds_only_its_own_command() -> None:
    from usdworld.cli.main import COMMANDS, commands_for

    assert commands_for(["-q", "edit", "W", "move", "car_0001"]) == ("edit",)
    assert commands_for(["--debug", "build", "photo.png"]) == ("build",)
    for args in ([], ["--help"], ["-q"], ["bogus"], ["--debug", "--help"]):
        assert commands_for(args) == tuple(COMMANDS)


def test_reading_a_render_scene_loads_neither_the_world_writer_nor_numpy_ma() -> None:
    """``usdworld render`` opens a world and reads its meshes: no authoring of worlds, no masked arrays."""
    loaded = _loaded_after(
        "import usdworld.authoring.inspect\n"
        "from pxr import Usd, UsdGeom\n"
        "from usdworld.render.scene import RenderScene\n"
        "stage = Usd.Stage.CreateInMemory()\n"
        "mesh = UsdGeom.Mesh.Define(stage, '/World/quad')\n"
        "mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])\n"
        "mesh.CreateFaceVertexCountsAttr([4])\n"
        "mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])\n"
        "assert RenderScene.from_stage(stage).n_triangles == 2",
        whole_names=True,
    )
    assert not loaded & {"usdworld.authoring.world", "usdworld.authoring.appearance", "numpy.ma"}


def test_a_build_loads_no_renderer() -> None:
    """The build reads the sun's model from ``usdworld.render.lighting``; the package loads its
    renderer, scene reader and camera modules only when one of their names is used."""
    probe = (
        "import json, sys\n"
        "import usdworld.pipeline\n"
        "before = sorted(m for m in sys.modules if m.startswith('usdworld.render'))\n"
        "from usdworld.render import Renderer, RenderScene\n"
        "import usdworld.render as r\n"
        "assert Renderer is r.renderer.Renderer and RenderScene is r.scene.RenderScene\n"
        "print(json.dumps(before))"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe], cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True, text=True, check=True
    )
    loaded = set(json.loads(out.stdout.splitlines()[-1]))
    assert "usdworld.render.lighting" in loaded
    assert not loaded & {"usdworld.render.renderer", "usdworld.render.scene", "usdworld.render.camera", "usdworld.render.batches"}


def test_an_edit_loads_no_shading_schemas_and_no_build_layout() -> None:
    """``usdworld edit`` moves and rotates without UsdShade/Sdr (only a restyle needs them) and
    without the build's placement draft (the editor turns footprints with usdworld.geometry.rotation)."""
    loaded = _loaded_after("import usdworld.cli.edit_cmd, usdworld.authoring.edits", whole_names=True)
    assert "usdworld.geometry.rotation" in loaded
    assert not loaded & {"pxr.UsdShade", "pxr.Sdr", "usdworld.layout.draft"}


#: Libraries ``usdworld build`` (labels and a camera file) never needs: the other commands'
#: extras (renderer, validators, CNN backends, servers, Dask), the ones a build left behind
#: (scipy, trimesh, rich), numpy's masked arrays' sibling packages it does not use, and the
#: standard library's statistics (with decimal and fractions: only for objects the image cuts off).
NOT_IN_A_BUILD = {
    "scipy", "trimesh", "torch", "transformers", "PIL", "rich", "pygments", "jsonschema", "pydantic", "tqdm",
    "matplotlib", "networkx", "moderngl", "glcontext", "imageio", "imageio_ffmpeg", "omni", "dask",
    "distributed", "starlette", "uvicorn", "filelock", "pandas", "sklearn",
    "statistics", "decimal", "fractions",
}
#: The stages of inputs a build from labels and a whole camera file does not have (detections,
#: ground points, a segmentation model, a depth map, no camera file: its EXIF reader too, the focal
#: length's, the lane lines' and the roll's estimates), the editor's
#: object index (written beside the crate layer of a large world only) and the light schemas'
#: module (the lights are authored by their schema type names).
OPTIONAL_STAGES = {
    "usdworld.io.detections", "usdworld.io.correspondences", "usdworld.io.depth_files",
    "usdworld.io.detector_labels", "usdworld.perception.classes", "usdworld.perception.dedupe",
    "usdworld.perception.refs", "usdworld.perception.streets", "usdworld.streets_stage",
    "usdworld.segment_stage", "usdworld.layout.focal_cues", "usdworld.geometry.lateral", "pxr.UsdLux",
    "usdworld.io.exif", "usdworld.authoring.editing.index", "usdworld.authoring.editing.index_file",
    "usdworld.geometry.focal", "usdworld.geometry.lanes", "usdworld.geometry.roll",
}
#: usdworld's own packages and modules that only other commands use.
NOT_IN_A_BUILD_USDWORLD = {
    "usdworld.render.renderer", "usdworld.render.scene", "usdworld.render.camera", "usdworld.render.batches",
    "usdworld.evaluation", "usdworld.export", "usdworld.synth", "usdworld.serve", "usdworld.batch",
    "usdworld.views", "usdworld.report_html", "usdworld.authoring.validate", "usdworld.authoring.user_assets",
}


def _command_state(argv: list[str], cwd: Path) -> dict:
    """Run ``usdworld ARGV`` as a user does (the console entry point, a fresh process) and return
    what an exit handler of that process read: its modules, whether the cyclic collector was on
    and how many objects were frozen."""
    probe = (
        "import atexit, gc, json, sys\n"
        "def report():\n"
        "    state = {'modules': sorted(sys.modules), 'collecting': gc.isenabled(), 'frozen': gc.get_freeze_count()}\n"
        "    print(json.dumps(state))\n"
        "atexit.register(report)\n"
        "from usdworld.cli.main import run\n"
        f"sys.argv = {['usdworld', *argv]!r}\n"
        "run()\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], cwd=cwd, env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


@pytest.fixture(scope="module")
def small_frame(tmp_path_factory) -> dict[str, Path]:
    """A 512x256 synthetic Cityscapes-format frame (labels, instances, camera)."""
    from usdworld.synth import make_street_scene, write_cityscapes_frame

    scene = make_street_scene(np.random.default_rng(3), 512, 256)
    return write_cityscapes_frame(scene, tmp_path_factory.mktemp("frame"), "t_000000_000001")


def test_the_whole_build_command_loads_no_heavy_extra_and_runs_without_the_cyclic_collector(small_frame, tmp_path) -> None:
    """``usdworld build``: what it has loaded and how it collects garbage when it exits."""
    files = small_frame
    argv = ["-q", "build", str(files["image"]), "--labels", str(files["labels"])]
    argv += ["--instances", str(files["instances"]), "--camera", str(files["camera"]), "-o", str(tmp_path / "world")]
    state = _command_state(argv, tmp_path)
    assert (tmp_path / "world" / "world.usda").is_file()
    loaded = set(state["modules"])
    assert not {m.split(".")[0] for m in loaded} & NOT_IN_A_BUILD
    assert not {m for m in loaded if m.startswith(tuple(NOT_IN_A_BUILD_USDWORLD))}
    assert not loaded & OPTIONAL_STAGES
    assert {"usdworld.pipeline", "usdworld.authoring.world", "pxr.UsdGeom", "cv2"} <= loaded  # it did build
    assert not state["collecting"]  # usdworld.cli.main.run: no cyclic collection in a build
    assert state["frozen"] > 10_000  # ... and the teardown's collection skips the start-up's objects


def test_the_whole_render_command_loads_neither_the_build_nor_usdlux(small_frame, tmp_path) -> None:
    """``usdworld render --write all``: it reads the world's lights without the UsdLux module and,
    looking for the photo of the comparisons (not beside this world), searches the demo folder
    without loading the build's pipeline; it runs without the cyclic collector."""
    from usdworld.cli.main import main

    files = small_frame
    world = tmp_path / "world"
    args = ["-q", "build", str(files["image"]), "--labels", str(files["labels"]), "--instances", str(files["instances"])]
    assert main([*args, "--camera", str(files["camera"]), "-o", str(world)]) == 0
    state = _command_state(["-q", "render", str(world), "-o", str(tmp_path / "out"), "--write", "all"], tmp_path)
    assert (tmp_path / "out" / "class.png").is_file()
    loaded = set(state["modules"])
    assert "usdworld.render.renderer" in loaded and "pxr.UsdGeom" in loaded  # it did render
    assert not loaded & {"pxr.UsdLux", "usdworld.pipeline", "usdworld.authoring.world"}
    assert not {m.split(".")[0] for m in loaded} & {"scipy", "trimesh", "torch", "PIL", "rich", "omni"}
    assert not state["collecting"]


def test_importing_the_build_loads_no_optional_input_stage() -> None:
    """The pipeline and the build command import the stages of detections, ground points, a
    segmentation model, a depth map or a missing camera file where those run, not with the module."""
    loaded = _loaded_after("import usdworld.pipeline, usdworld.cli.build_cmd", whole_names=True)
    assert "usdworld.perception.objects" in loaded and "usdworld.depth_stage" in loaded
    assert not loaded & OPTIONAL_STAGES
    assert not {m.split(".")[0] for m in loaded} & {"statistics", "decimal", "fractions"}


def test_the_whole_edit_command_takes_its_lock_without_filelock(small_frame, tmp_path) -> None:
    """``usdworld edit W move``: on POSIX the edit lock is ``fcntl.flock`` itself (filelock and its
    logging, hashing and decimal modules are not loaded), and a move needs no UsdSemantics."""
    from usdworld.authoring.edits import WorldEditor
    from usdworld.cli.main import main

    files = small_frame
    world = tmp_path / "world"
    args = ["-q", "build", str(files["image"]), "--labels", str(files["labels"])]
    args += ["--instances", str(files["instances"]), "--camera", str(files["camera"]), "-o", str(world)]
    assert main(args) == 0
    with WorldEditor(world) as editor:
        name = sorted(o.name for o in editor.objects())[0]
    state = _command_state(["-q", "edit", str(world), "move", name, "--by", "0.5,0", "--force"], tmp_path)
    loaded = set(state["modules"])
    assert "usdworld.authoring.editing.transaction" in loaded  # it did edit, under the lock
    assert not loaded & {"filelock", "pxr.UsdSemantics", "usdworld.authoring.editing.user_object", "decimal"}
    with WorldEditor(world) as editor:
        assert [h.op for h in editor.history()] == ["move"]


def test_the_layer_prefetch_starts_before_pxr_usd_is_imported() -> None:
    """An edit starts parsing the world's layers on a thread as soon as pxr.Sdf is loaded:
    ``usdworld.authoring.stages`` (the prefetch, the schema registration) does not import pxr.Usd,
    so its import (~20 ms) overlaps the parse too."""
    loaded = _loaded_after("import usdworld.authoring.stages", whole_names=True)
    assert "pxr.Sdf" in loaded
    assert "pxr.Usd" not in loaded


def test_the_suite_and_its_probes_destroy_layers_synchronously() -> None:
    """tests/conftest.py: no detached destruction left running when a test process exits."""
    from pxr import Tf

    assert Tf.GetEnvSetting("WORK_SYNCHRONIZE_ASYNC_DESTROY_CALLS") is True
    loaded = _loaded_after("from pxr import Tf\nassert Tf.GetEnvSetting('WORK_SYNCHRONIZE_ASYNC_DESTROY_CALLS') is True")
    assert "pxr" in loaded
