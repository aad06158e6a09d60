"""Shared helpers of the ``usdworld serve`` tests (imported by the other test_serve* modules).

The demo world (``usdworld demo``: 38 objects, source camera, photo in the package's demo
data) is built once per test session and copied for each test; servers started in a
subprocess are stopped with SIGINT, like Ctrl-C.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

_TEMPLATE: dict[str, Path] = {}
URL_LINE = re.compile(r"^open (http://\S+/\?token=(\S+))$")
#: Debian's Chromium, which the browser tests drive (Playwright's own download is not used).
CHROMIUM = Path(os.environ.get("USDWORLD_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]


def demo_world(tmp_path_factory, dst: Path) -> Path:
    """A fresh copy of the demo world in ``dst``; returns its root layer."""
    if "demo" not in _TEMPLATE:
        from usdworld.demo import demo_request
        from usdworld.pipeline import build

        out = tmp_path_factory.mktemp("serve_template") / "demo"
        build(demo_request(out))
        _TEMPLATE["demo"] = out
    shutil.copytree(_TEMPLATE["demo"], dst)
    return dst / "world.usda"


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class ServerProcess:
    """``python -m usdworld serve WORLD --port 0 ...`` in a subprocess, with its URL and token."""

    def __init__(self, world: Path, *extra: str, timeout_s: float = 60.0) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "usdworld", "serve", str(world), "--port", "0", *extra],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.lines: list[str] = []
        deadline = time.monotonic() + timeout_s
        self.url = self.token = ""
        assert self.proc.stdout is not None
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.lines.append(line.rstrip("\n"))
            m = URL_LINE.match(line.strip())
            if m:
                self.url, self.token = m.group(1), m.group(2)
                break
        if not self.url:
            self.stop()
            raise RuntimeError(
                f"usdworld serve printed no URL: {self.lines} {self.proc.stderr.read() if self.proc.stderr else ''}"
            )
        self.base = self.url.split("/?", 1)[0]

    def stop(self, timeout_s: float = 15.0) -> tuple[int, str, str]:
        """Ctrl-C (SIGINT); returns (exit code, rest of stdout, stderr)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            out, err = self.proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, err = self.proc.communicate()
        return self.proc.returncode, out, err


@dataclass(frozen=True)
class Targets:
    """Objects of the demo world the tests edit, chosen from the world itself (the demo's
    content follows the pipeline, so no name or position is hard-coded).

    Attributes:
        car: an active car on the road, the nearest one the source camera sees well.
        car_xy: its position (x, y).
        car_to: a point the rules let ``car`` move to, with a margin (on the road, free, in view).
        add_at: a free point on the road, in view, for a new car (also clear of ``car_to``).
        other_car: another active car (moving ``car`` onto it breaks the fit rule).
        other_xy: its position.
        sidewalk: a point on the sidewalk (a car may not stand there).
        person: an active person (to delete).
        count: number of objects.
    """

    car: str
    car_xy: tuple[float, float]
    car_to: tuple[float, float]
    add_at: tuple[float, float]
    other_car: str
    other_xy: tuple[float, float]
    sidewalk: tuple[float, float]
    person: str
    count: int


#: Slack (length, width) in metres a chosen free spot keeps around a car.
MARGIN_LW = (1.5, 0.8)


def find_targets(world: Path) -> Targets:
    """Pick the objects and points the serve tests use."""
    import numpy as np

    from usdworld.authoring.edits import WorldEditor
    from usdworld.layout import permissible as rules
    from usdworld.render.camera import camera_from_usd

    with WorldEditor(world) as editor:
        objects = editor.objects()
        ground = editor.ground()
        surfaces, _ = rules.surface_at(np.array([o.position_world[:2] for o in objects]), ground)
        pose = camera_from_usd(editor.stage.GetPrimAtPath("/World/SourceCamera"), 1024, 512)
        cam_from_world = np.linalg.inv(pose.world_from_cam)

        def in_view(xy: tuple[float, float], margin_px: float = 80.0) -> bool:
            p = cam_from_world @ np.array([xy[0], xy[1], 0.0, 1.0])
            u, v, w = pose.K @ p[:3]
            return p[2] > 4.0 and margin_px < u / w < 1024 - margin_px and 300 < v / w < 500

        live = [o for o in objects if o.active]
        table = rules.Footprints(
            tuple(o.name for o in live),
            tuple(o.class_name for o in live),
            np.array([o.position_world[:2] for o in live]),
            np.array([o.size_lw for o in live]),
            np.radians([o.yaw_deg for o in live]),
        )

        def free(xy: tuple[float, float], size_lw, yaw_deg: float, others) -> bool:
            cand = rules.Candidate("car", np.array(xy), np.add(size_lw, MARGIN_LW), np.radians(yaw_deg))
            return in_view(xy) and not rules.check_placement(cand, others, ground, editor.surface_rules)

        cars = sorted(
            (o for o, s in zip(objects, surfaces) if o.active and o.class_name == "car" and s == "road"),
            key=lambda o: o.position_world[0],
        )
        steps = [(dx, dy) for dx in (2.5, -2.5, 3.5, -3.5, 5.0, 6.5) for dy in (0.0, 0.4, -0.4, 0.8, -0.8, 1.2, -1.2)]
        choice = None
        # A car cut by the image border may stand with its centre at the border (half of it in
        # view); where it goes must be well inside.
        for car in (c for c in cars if in_view(c.position_world[:2], margin_px=0.0)):
            x, y = car.position_world[:2]
            others = table.without(car.name)
            to = next(
                (
                    (round(x + dx, 2), round(y + dy, 2))
                    for dx, dy in steps
                    if free((x + dx, y + dy), car.size_lw, car.yaw_deg, others)
                ),
                None,
            )
            if to is not None:
                choice = (car, to)
                break
        if choice is None:
            raise RuntimeError(f"no car of {world} can be moved in view; the demo world changed too much")
        car, to = choice
        moved = rules.Footprints(
            table.names,
            table.classes,
            np.where(np.array(table.names)[:, None] == car.name, np.array(to), table.centers),
            table.size_lw,
            table.yaw,
        )
        # Candidate spots: each road triangle's centroid and the points halfway to its corners.
        corners = ground.triangles["road"][:, :, :2]
        centroids = corners.mean(axis=1)
        road = np.concatenate([centroids, ((corners + centroids[:, None, :]) / 2).reshape(-1, 2)])
        add_at = next(
            (
                (round(float(p[0]), 2), round(float(p[1]), 2))
                for p in sorted(road, key=lambda p: (float(p[0]), float(p[1])))
                if free((float(p[0]), float(p[1])), (4.5, 2.0), car.yaw_deg, moved)
            ),
            None,
        )
        if add_at is None:
            raise RuntimeError(f"no free road point in view in {world}")
        other = next(o for o in cars if o.name != car.name)
        person = next(o for o in live if o.class_name == "person")
        walk = [p for p in ground.triangles["sidewalk"][:, :, :2].mean(axis=1) if in_view((p[0], p[1]))]
        if not walk:
            raise RuntimeError(f"no sidewalk in view in {world}")
        sidewalk = min(walk, key=lambda p: float(np.linalg.norm(p - np.array(car.position_world[:2]))))
        return Targets(
            car=car.name,
            car_xy=(float(car.position_world[0]), float(car.position_world[1])),
            car_to=to,
            add_at=add_at,
            other_car=other.name,
            other_xy=(float(other.position_world[0]), float(other.position_world[1])),
            sidewalk=(round(float(sidewalk[0]), 3), round(float(sidewalk[1]), 3)),
            person=person.name,
            count=len(objects),
        )
