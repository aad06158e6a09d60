"""usdworld: one street photo to a layered, editable USD world.

Importing the package registers the ``UsdWorldProvenanceAPI`` / ``UsdWorldSceneAPI``
codeless schemas with OpenUSD. This must happen before the first stage is opened
in the process (the schema registry is built then), so import usdworld first.
"""

from __future__ import annotations

__version__ = "0.1.0"


def _register_schema_plugin() -> None:
    from pxr import Plug

    from usdworld.resources import schemas_dir

    Plug.Registry().RegisterPlugins(str(schemas_dir()))


_register_schema_plugin()
