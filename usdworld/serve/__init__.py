"""``usdworld serve``: edit a world with the mouse in a web page (three.js), through the editing engine.

Modules:

* :mod:`usdworld.serve.session` -- one world opened for editing: object and camera JSON,
  the scene as GLB, the edit operations (the :class:`~usdworld.authoring.edits.WorldEditor`
  API, with its lock, rules and edits layer) and a redo stack;
* :mod:`usdworld.serve.payloads` -- validation of the JSON request bodies;
* :mod:`usdworld.serve.scene_glb` -- the composed stage as a glTF binary, one node per object;
* :mod:`usdworld.serve.app` -- the Starlette application (routes, session token, size limits);
* :mod:`usdworld.serve.server` -- binding a loopback socket and running uvicorn until Ctrl-C.

The page itself (``static/``) is built from ``webapp/`` by ``tools/build_webapp.sh``; the
built files are committed, so the package works offline and without npm.
"""
