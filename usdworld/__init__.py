"""usdworld: one street photo to a layered, editable USD world.

Importing the package is cheap: it loads neither OpenUSD (``pxr``) nor numpy. The
``UsdWorldProvenanceAPI`` / ``UsdWorldSceneAPI`` codeless schemas are registered with
OpenUSD when :mod:`usdworld.authoring` is first imported, which every usdworld module that
opens or creates a stage (authoring, render, export, synth, evaluation) does before it
can. Code that opens stages with ``pxr`` directly should ``import usdworld.authoring``
first: the schema registry is built when the first stage is opened.
"""

from __future__ import annotations

__version__ = "0.1.0"
