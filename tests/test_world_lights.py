"""The world's lights: authored as UsdLux, read back by the renderer, exported to GLB; synth's overcast scenes."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux

import usdworld.authoring  # noqa: F401  (registers the schema plugin first)
from usdworld.authoring.lights import define_lights
from usdworld.export.gltf import add_sun, sun_light
from usdworld.layout.model import LightRig
from usdworld.render.lighting import Lighting, overcast_lighting, sun_direction
from usdworld.render.world_lights import lighting_from_stage
from usdworld.synth import make_street_scene
from usdworld.world_files import LIGHTS_PATH, SKY_PATH, SUN_PATH

RIG = LightRig(
    sun_direction_world=sun_direction(30.0, 40.0),
    sun_color=np.array([1.1, 1.05, 0.95]),
    sky_ambient=np.array([0.3, 0.33, 0.4]),
    ground_ambient=np.array([0.18, 0.17, 0.16]),
    sky_zenith_srgb=np.array([0.3, 0.5, 0.8]),
    sky_horizon_srgb=np.array([0.8, 0.85, 0.9]),
)


def _stage() -> Usd.Stage:
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/World")
    return stage


def test_authored_lights_read_back_as_the_same_lighting() -> None:
    stage = _stage()
    define_lights(stage, RIG, None)
    sun = UsdLux.DistantLight(stage.GetPrimAtPath(SUN_PATH))
    assert sun and UsdLux.DomeLight(stage.GetPrimAtPath(SKY_PATH))
    assert sun.GetIntensityAttr().Get() == pytest.approx(1.1)
    assert sun.GetAngleAttr().Get() == pytest.approx(0.53)
    # the light shines along its -Z: away from the sun
    m = UsdGeom.Xformable(sun.GetPrim()).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    shine = m.TransformDir(Gf.Vec3d(0, 0, -1))
    assert np.allclose(np.array(shine), -RIG.sun_direction_world, atol=1e-6)
    light = lighting_from_stage(stage)
    assert np.allclose(light.sun_direction_world, RIG.sun_direction_world, atol=1e-6)
    for name in ("sun_color", "sky_ambient", "ground_ambient", "sky_zenith_srgb", "sky_horizon_srgb"):
        assert np.allclose(getattr(light, name), getattr(RIG, name), atol=1e-6), name
    lights = stage.GetPrimAtPath(LIGHTS_PATH)
    assert lights.GetAttribute("usdworld:lightMethod").Get() == "no_evidence"
    assert lights.GetAttribute("usdworld:sunElevation").Get() == pytest.approx(math.radians(40.0), abs=1e-6)


def test_a_world_without_lights_renders_with_the_default_and_edits_count() -> None:
    stage = _stage()
    default = Lighting()
    assert lighting_from_stage(stage) is not None
    assert np.array_equal(lighting_from_stage(stage).sun_direction_world, default.sun_direction_world)
    define_lights(stage, RIG, None)
    with Usd.EditContext(stage, stage.GetSessionLayer()):  # an edit over the base opinion
        UsdLux.DistantLight(stage.GetPrimAtPath(SUN_PATH)).GetIntensityAttr().Set(0.0)
        UsdLux.DomeLight(stage.GetPrimAtPath(SKY_PATH)).GetExposureAttr().Set(1.0)
    light = lighting_from_stage(stage)
    assert np.allclose(light.sun_color, 0.0)
    assert np.allclose(light.sky_ambient, 2.0 * RIG.sky_ambient)


def test_glb_sun_is_a_directional_light_shining_away_from_the_sun_in_y_up() -> None:
    stage = _stage()
    define_lights(stage, RIG, None)
    light, node = sun_light(stage)
    assert light["type"] == "directional" and light["intensity"] == pytest.approx(1.1)
    x, y, z, w = node["rotation"]
    shine = np.array(Gf.Rotation(Gf.Quatd(w, Gf.Vec3d(x, y, z))).TransformDir(Gf.Vec3d(0, 0, -1)))
    d = RIG.sun_direction_world
    assert np.allclose(shine, -np.array([d[0], d[2], -d[1]]), atol=1e-6)  # Z up -> Y up: (x, z, -y)
    tree = {"scenes": [{"nodes": [0]}], "nodes": [{"name": "World"}]}
    add_sun(tree, (light, node))
    assert tree["extensionsUsed"] == ["KHR_lights_punctual"]
    assert tree["scenes"][0]["nodes"] == [0, 1]
    assert tree["nodes"][1]["extensions"] == {"KHR_lights_punctual": {"light": 0}}
    assert sun_light(_stage()) is None


def test_synth_overcast_leaves_every_other_draw_alone() -> None:
    # rng.random() after the scene and the scene's own draws as on the commit before overcast scenes
    for seed, after, fx, overcast in ((7, 0.2926420351358663, 166.80133824390796, False), (9, 0.36946191556912045, 140.15340036181698, True)):
        rng = np.random.default_rng(seed)
        scene = make_street_scene(rng, 256, 128)
        assert rng.random() == after
        assert scene.camera.fx == pytest.approx(fx, abs=1e-9)
        assert scene.overcast is overcast
    share = np.mean([make_street_scene(np.random.default_rng(s), 64, 32).overcast for s in range(50)])
    assert 0.15 <= share <= 0.45


def test_overcast_lighting_has_no_sun_and_lights_the_ground_like_the_default_sun() -> None:
    grey = overcast_lighting()
    assert np.allclose(grey.sun_color, 0.0)
    sunny = Lighting()
    up = sunny.sky_ambient + sunny.sun_color * math.sin(math.radians(45.0))
    assert np.allclose(grey.sky_ambient, up)


def test_evaluate_reports_the_sun_error_against_synth_truth() -> None:
    from usdworld.evaluation.evaluate import light_errors
    from usdworld.evaluation.ground_truth import GroundTruth
    from usdworld.perception.light import LightEstimate

    stage = _stage()
    nan3 = np.full(3, np.nan)
    fitted = LightEstimate(
        "cast_shadows", False, math.radians(30.0), math.radians(40.0), 3.0, 0.1, 0.5, 5, 100, 4, nan3, nan3, "none"
    )
    define_lights(stage, RIG, fitted)
    truth = GroundTruth("synth", "world", (), "s_gt.json", "0" * 64, None, sun_direction(-20.0, 50.0), False)
    errors = light_errors(stage, truth)
    assert errors["azimuth_error_deg"] == pytest.approx(50.0, abs=1e-3)
    assert errors["elevation_error_deg"] == pytest.approx(10.0, abs=1e-3)
    overcast_truth = GroundTruth("synth", "world", (), "s_gt.json", "0" * 64, None, sun_direction(0.0, 50.0), True)
    errors = light_errors(stage, overcast_truth)
    assert (errors["true_overcast"], errors["overcast"], errors["azimuth_error_deg"]) == (True, False, None)
    assert light_errors(_stage(), truth) is None  # an old world: no lights


def test_the_lights_are_authored_as_usdlux_writes_them_without_its_module() -> None:
    """``define_lights`` writes the specs ``UsdLux.DistantLight/DomeLight.Define`` and their
    ``Create*Attr`` write (same layer text), in a process that never loads ``pxr.UsdLux``."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    probe = (
        "import json, sys\n"
        "import numpy as np\n"
        "from pxr import Usd, UsdGeom\n"
        "import usdworld.authoring\n"
        "from usdworld.authoring.lights import define_lights\n"
        "from usdworld.layout.model import LightRig\n"
        f"rig = LightRig(*(np.array(v) for v in {[list(map(float, v)) for v in vars(RIG).values()]!r}))\n"
        "stage = Usd.Stage.CreateInMemory()\n"
        "UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)\n"
        "UsdGeom.Xform.Define(stage, '/World')\n"
        "define_lights(stage, rig, None)\n"
        "layer = stage.GetRootLayer().ExportToString()\n"
        "print(json.dumps({'usdlux': 'pxr.UsdLux' in sys.modules, 'layer': layer}))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe], cwd=repo, env={**os.environ, "PYTHONPATH": str(repo)},
        capture_output=True, text=True, check=True,
    )
    state = json.loads(out.stdout.splitlines()[-1])
    assert not state["usdlux"]

    stage = _stage()  # the same lights through UsdLux's schema classes
    define_lights(stage, RIG, None)
    for path in (SUN_PATH, SKY_PATH):
        stage.RemovePrim(path)
    sun = UsdLux.DistantLight.Define(stage, SUN_PATH)
    colour = Gf.Vec3f(*(RIG.sun_color / RIG.sun_color.max()).tolist())
    sun.CreateColorAttr(colour)
    sun.CreateIntensityAttr(float(RIG.sun_color.max()))
    sun.CreateAngleAttr(0.53)
    from usdworld.authoring.lights import sun_orientation

    UsdGeom.Xformable(sun.GetPrim()).AddOrientOp().Set(sun_orientation(RIG.sun_direction_world))
    sky = UsdLux.DomeLight.Define(stage, SKY_PATH)
    sky.CreateColorAttr(Gf.Vec3f(*(RIG.sky_ambient / RIG.sky_ambient.max()).tolist()))
    sky.CreateIntensityAttr(float(RIG.sky_ambient.max()))
    assert state["layer"] == stage.GetRootLayer().ExportToString()
