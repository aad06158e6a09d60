"""Time one non-destructive edit on a 200-object world (in-process, interpreter start-up excluded).

Generates a world: a synthetic Cityscapes-style frame (straight road, sidewalks, two cars
and a person) is built with ``usdworld.pipeline.build``, then its base layer is filled to
200 objects by copying those prims onto a grid (cars on the road, people on the
sidewalks). One :class:`~usdworld.authoring.edits.WorldEditor` then makes many edits,
each a full transaction (lock, sync, permissibility rules, authoring, history, atomic
save with fsync); the median per operation is printed, ``move`` first.

Usage::

    python tools/bench_edit.py [--edits 200] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

W, H, F, CAM_H = 1024, 512, 500.0, 1.5
ROAD_HALF_WIDTH_M = 20.0


def _frame(out: Path) -> dict[str, Path]:
    """A synthetic frame: road |y| < 20 m, sidewalks beyond, two cars, one person."""
    labels = np.full((H, W), 23, np.uint8)
    inst = labels.astype(np.uint16)
    for v in range(H // 2 + 2, H):
        d = F * CAM_H / (v - H / 2)
        labels[v, :] = 8
        u_l, u_r = (round(W / 2 - F * y / d) for y in (ROAD_HALF_WIDTH_M, -ROAD_HALF_WIDTH_M))
        labels[v, max(u_l, 0) : max(min(u_r, W), 0)] = 7
    inst = labels.astype(np.uint16)

    def obj(cls_id: int, k: int, depth: float, y: float, w_m: float, h_m: float) -> None:
        vb = round(H / 2 + F * CAM_H / depth)
        vt = round(vb - F * h_m / depth)
        uc, hw = W / 2 - F * y / depth, F * w_m / depth / 2
        labels[vt:vb, int(uc - hw) : int(uc + hw)] = cls_id
        inst[vt:vb, int(uc - hw) : int(uc + hw)] = cls_id * 1000 + k

    obj(26, 1, 20.0, 1.5, 1.8, 1.5)
    obj(26, 2, 14.0, -2.5, 1.8, 1.5)
    obj(24, 1, 25.0, -22.0, 0.6, 1.75)
    files = {k: out / f"bench_{k}.png" for k in ("leftImg8bit", "gtFine_labelIds", "gtFine_instanceIds")}
    cv2.imwrite(str(files["leftImg8bit"]), np.dstack([labels * 5] * 3))
    cv2.imwrite(str(files["gtFine_labelIds"]), labels)
    cv2.imwrite(str(files["gtFine_instanceIds"]), inst)
    camera = out / "bench_camera.json"
    camera.write_text(
        json.dumps({"fx": F, "fy": F, "cx": W / 2, "cy": H / 2, "height_m": CAM_H, "pitch_deg": 0.0})
    )
    return {**files, "camera": camera}


def make_world(folder: Path, n_objects: int = 200) -> Path:
    """Build the synthetic world and fill its base layer to ``n_objects`` objects."""
    from pxr import Gf, Sdf

    from usdworld.authoring.stages import base_layer_file
    from usdworld.pipeline import BuildRequest, build

    src = folder / "src"
    src.mkdir(parents=True)
    f = _frame(src)
    world = folder / "world"
    build(
        BuildRequest(
            image=f["leftImg8bit"],
            labels=f["gtFine_labelIds"],
            instances=f["gtFine_instanceIds"],
            camera=f["camera"],
            output=world,
        )
    )
    base = Sdf.Layer.FindOrOpen(str(base_layer_file(world)))  # the root's last sublayer
    src_layer = Sdf.Layer.CreateAnonymous(".usda")
    src_layer.TransferContent(base)  # the built prims serve as templates
    objects = base.GetPrimAtPath("/World/Objects")
    for name in list(objects.nameChildren.keys()):
        del objects.nameChildren[name]
    spots = [
        ("car_0001", x, y)
        for x in np.arange(12.0, 76.0, 5.5)
        for y in np.arange(-18.0, 18.5, 3.0)
        if abs(y) < x - 4
    ]
    spots += [("person_0001", x, y) for x in np.arange(20.0, 76.0, 2.0) for y in (-24.0, -26.0, 24.0, 26.0)]
    spots = spots[:n_objects]
    counters: dict[str, int] = {}
    for proto, x, y in spots:
        cls = proto.rsplit("_", 1)[0]
        counters[cls] = counters.get(cls, 0) + 1
        path = Sdf.Path(f"/World/Objects/{cls}_{counters[cls]:04d}")
        Sdf.CopySpec(src_layer, f"/World/Objects/{proto}", base, path)
        base.GetAttributeAtPath(path.AppendProperty("xformOp:translate")).default = Gf.Vec3d(
            float(x), float(y), 0.15 if cls == "person" else 0.0
        )
    base.Save()
    return world / "world.usda"


def _median_ms(fn, n: int) -> float:
    times = []
    for i in range(n):
        t0 = time.perf_counter()
        fn(i)
        times.append(time.perf_counter() - t0)
    return 1000.0 * statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--edits", type=int, default=200, help="edits per operation timed")
    parser.add_argument("--keep", type=Path, help="folder to generate the world in (kept)")
    args = parser.parse_args(argv)
    from usdworld.authoring.edits import WorldEditor

    folder = args.keep or Path(tempfile.mkdtemp(prefix="bench_edit_"))
    root = make_world(folder)
    editor = WorldEditor(root)
    n_obj = len(editor.objects())

    def add_then_undo(i: int) -> float:
        t0 = time.perf_counter()
        editor.add("person", (30.0 + 1.5 * (i % 20), -21.0))
        spent = time.perf_counter() - t0
        editor.undo()
        return spent

    def open_and_move(i: int) -> None:
        with WorldEditor(root) as fresh:
            fresh.move("car_0060", by=(0.5 if i % 2 == 0 else -0.5, 0.0))

    n = args.edits
    results = {
        "move": _median_ms(lambda i: editor.move("car_0050", by=(0.5 if i % 2 == 0 else -0.5, 0.0)), n),
        "rotate": _median_ms(lambda i: editor.rotate("car_0051", 10.0 * (i % 2)), n),
        "restyle": _median_ms(lambda i: editor.restyle("car_0052", "#c03030" if i % 2 else "#2a4d8f"), n),
        "replace": _median_ms(
            lambda i: editor.replace("car_0053", "car", variant=("sedan", "hatchback")[i % 2]), n
        ),
        "delete+undo": _median_ms(lambda i: (editor.delete("car_0054"), editor.undo()), n) / 2,
        "add": 1000.0 * statistics.median(add_then_undo(i) for i in range(min(n, 50))),
        "undo": _median_ms(lambda i: editor.undo(), min(n, 100)),
        "open+move": _median_ms(open_and_move, min(n, 20)),
    }
    steps = len(editor.history())
    print(f"world: {root} ({n_obj} objects); history grew to about {4 * n} steps")
    print(f"median time for one edit (move, editor open): {results['move']:.1f} ms")
    for op, ms in results.items():
        print(f"  {op:<12} {ms:7.1f} ms")
    print(f"({steps} steps left in the history)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
