"""USD authoring: stages, layers, schema use, assets and validation (the only pxr users besides render).

Importing this package registers usdworld's codeless schemas (``UsdWorldProvenanceAPI``,
``UsdWorldSceneAPI``) with OpenUSD. It must happen before the first stage is opened in the
process (the schema registry is built then); every usdworld module that opens a stage
imports from here, so it does. Registering twice is harmless.
"""

from __future__ import annotations

from usdworld.authoring.stages import register_schemas

register_schemas()
