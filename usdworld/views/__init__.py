"""Several views, one world (issue 19): camera rigs such as a nuScenes sample's six cameras.

Modules, in the package's one-way order:

* :mod:`~usdworld.views.types`: the views of a rig as frozen dataclasses (io level);
* :mod:`~usdworld.views.manifest`: ``usdworld build --views VIEWS.json`` (io);
* :mod:`~usdworld.views.nuscenes`: ``--layout nuscenes --views INFO`` (io, an mmdetection3d info file);
* :mod:`~usdworld.views.rig`: each view's camera from its known pose, and its ground frame in the world (layout);
* :mod:`~usdworld.views.fusion`: association and fusion of the views' objects (layout);
* :mod:`~usdworld.views.ground`: one ground from every view's surfaces (layout);
* :mod:`~usdworld.views.unevenness`: how far the ground departs from the plane under the car, from the objects (layout);
* :mod:`~usdworld.views.build`: :func:`build_views`, wiring the single-image stages per view (pipeline).

The USD side (extra cameras, multi-view provenance) is :mod:`usdworld.authoring.rig`.
"""
