"""The parts of the world editor (:class:`usdworld.authoring.edits.WorldEditor` composes them).

* :mod:`.transaction` -- the lock on the edits layer, syncing it with the file, the atomic save;
* :mod:`.journal` -- the history and undo arrays in the layer's customLayerData, and undo;
* :mod:`.state` -- the objects, their footprints and the ground as the composed stage has them now;
* :mod:`.operations` -- move, rotate, delete, add, replace, reset (rules gated by
  :mod:`usdworld.layout.permissible`);
* :mod:`.restyle` -- the colour edit and its helpers;
* :mod:`.user_object` -- what an added object is authored with;
* :mod:`.orphans` -- edits whose target prim no longer exists.
"""
