"""USD authoring: stages, layers, schema use, assets and validation (the only pxr users besides render)."""
