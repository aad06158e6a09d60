"""Names of a world's files and prims (leaf module): where everything of a world lives.

A world folder holds the root layer, which stacks the edits layer over the base layer, the
ground's crate layer and the copied class assets. Modules that only need to find things in
a world (the editor, the output-folder guard, batch resume) import these names from here,
without the authoring modules and the USD libraries that writing a world needs
(:mod:`usdworld.authoring.world`).
"""

from __future__ import annotations

#: The root layer, relative to the world folder.
ROOT_LAYER = "world.usda"
#: The layer the build writes (never edited), as text. Find a world's base layer through its
#: root's sublayers (the last one), never by this name: a large world's is :data:`BASE_CRATE_LAYER`.
BASE_LAYER = "layers/base.usda"
#: The same layer in USD's binary crate format, which the build writes for a world of at least
#: ``AuthoringParams.large_world_min_objects`` objects (:mod:`usdworld.parameters.authoring`).
BASE_CRATE_LAYER = "layers/base.usdc"
#: The layer every edit goes to (the root's first sublayer).
EDITS_LAYER = "layers/edits.usda"
#: A drive's time (ego trajectory, moving objects' samples) as a crate layer, between edits and base.
DRIVE_LAYER = "layers/drive.usdc"
#: The ground meshes' crate layer.
GROUND_LAYER = "layers/ground.usdc"
#: The folder the class assets are copied into.
ASSETS_DIR = "assets"
#: The default prim.
WORLD_PATH = "/World"
#: Parent of every placed object.
OBJECTS_PATH = "/World/Objects"
#: Parent of the ground surfaces.
GROUND_PATH = "/World/Ground"
#: The camera the photo was taken with.
CAMERA_PATH = "/World/SourceCamera"
#: Parent of the world's lights (with their provenance).
LIGHTS_PATH = "/World/Lights"
#: The sun: a DistantLight.
SUN_PATH = "/World/Lights/Sun"
#: The sky: a DomeLight.
SKY_PATH = "/World/Lights/Sky"
