"""A campaign of whole ``usdworld build`` runs on random hostile inputs; prints a table of outcomes.

Usage: PYTHONPATH=$PWD python tools/fuzz_build.py N [--seed S] [--timeout 10] [--keep DIR]

Each case writes a tiny photo and random input files (detections JSON or KITTI labels,
camera files of the three kinds, ground points, polygons, label/instance maps, depth
maps, CLI options), some well-formed and some hostile (huge, non-finite, negative,
mistyped numbers; truncated or mutated bytes), and runs ``python -m usdworld build`` as a
subprocess into ``-o`` an existing world folder. Outcomes:

* clean error: exit 2 with exactly one ``error:`` line on stderr (no warnings before it);
* success: exit 0;
* internal error: exit 1, or exit 2 with more than one line;
* crash: killed by a signal (negative return code) or another exit code;
* hang: still running after ``--timeout`` seconds (10 by default).

After every failed build, the existing world folder must be byte-for-byte unchanged.
Exits 1 when any case was an internal error, crash or hang, or changed the world.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

import cv2
import numpy as np

HOSTILE = [0, -1, 0.5, 1e-300, 1e10, -1e10, 2**31, 1e19, 1e308, -1e308, "nan", "inf", "-inf", None, "x", [], True]
W, H = 96, 64
#: Cases listed per bad outcome (with their arguments, for a rerun).
SHOWN = 10


def _num(rng: random.Random, sane: float, spread: float = 0.5) -> object:
    """Mostly a plausible value near ``sane``, sometimes a hostile one."""
    if rng.random() < 0.25:
        v = rng.choice(HOSTILE)
        return float(v) if v in ("nan", "inf", "-inf") else v
    return sane * (1 + rng.uniform(-spread, spread))


def _mutate(rng: random.Random, data: bytes) -> bytes:
    if not data or rng.random() < 0.7:
        return data
    if rng.random() < 0.5:
        return data[: rng.randrange(len(data))]
    i = rng.randrange(len(data))
    return data[:i] + bytes([rng.randrange(256)]) + data[i + 1 :]


def _dumps(doc: object) -> bytes:
    return json.dumps(doc).encode()


def _box(rng: random.Random) -> list[object]:
    x, y = rng.uniform(0, W - 10), rng.uniform(H / 3, H - 10)
    return [_num(rng, x), _num(rng, y), _num(rng, x + 10), _num(rng, y + 8)]


def _case(rng: random.Random, folder: Path) -> list[str]:
    """Write one case's inputs into ``folder``; return the build's extra arguments."""
    image = np.full((H, W, 3), 90, np.uint8)
    image[H // 2 :] = 50
    ok, buf = cv2.imencode(".png", image)
    (folder / "img.png").write_bytes(_mutate(rng, buf.tobytes()) if rng.random() < 0.1 else buf.tobytes())
    args: list[str] = []
    files: dict[str, tuple[str, bytes]] = {}
    if rng.random() < 0.6:
        if rng.random() < 0.5:
            dets = [{"class": rng.choice(["car", "person", "truck", "zeppelin"]), "box": _box(rng)} for _ in range(rng.randrange(0, 5))]
            if dets and rng.random() < 0.3:
                dets[0]["polygon"] = [[_num(rng, 10), _num(rng, 40)], [_num(rng, 30), _num(rng, 40)], [_num(rng, 20), _num(rng, 60)]]
            files["--detections"] = ("d.json", _dumps({"detections": dets}))
        else:
            lines = []
            for _ in range(rng.randrange(0, 5)):
                b = _box(rng)
                lines.append(f"{rng.choice(['Car', 'Pedestrian', 'Tram'])} 0 0 0 {' '.join(str(v) for v in b)} 1.5 1.6 3.9 0 1.6 10 0")
            files["--detections"] = ("d.txt", ("\n".join(lines) + "\n").encode())
    elif rng.random() < 0.5:
        labels = np.full((H, W), 7, np.uint8)  # road
        labels[: H // 2] = 11  # building
        labels[40:52, 20:40] = 26  # car
        inst = labels.astype(np.uint16)
        inst[40:52, 20:40] = 26000
        files["--labels"] = ("l.png", _mutate(rng, cv2.imencode(".png", labels)[1].tobytes()))
        if rng.random() < 0.5:
            files["--instances"] = ("i.png", _mutate(rng, cv2.imencode(".png", inst)[1].tobytes()))
    else:
        poly = {"imgWidth": _num(rng, W, 0) if rng.random() < 0.9 else 7, "imgHeight": H, "objects": [
            {"label": "road", "polygon": [[0, H // 2], [W, H // 2], [W, H], [0, H]]},
            {"label": "car", "polygon": [[_num(rng, 20), _num(rng, 40)], [_num(rng, 40), 40], [40, _num(rng, 52)], [20, 52]]},
        ]}
        files["--polygons"] = ("p.json", _dumps(poly))
    kind = rng.choice(["none", "plain", "cityscapes", "kitti", "kitti+plane"])
    f, cx, cy = 80.0, W / 2, H / 2
    if kind == "plain":
        files["--camera"] = ("c.json", _dumps({"K": [[_num(rng, f), 0, _num(rng, cx)], [0, _num(rng, f), _num(rng, cy)], [0, 0, 1]],
                                               "height_m": _num(rng, 1.6), "pitch_deg": _num(rng, 1.0), "yaw_deg": _num(rng, 0.0)}))
    elif kind == "cityscapes":
        files["--camera"] = ("c.json", _dumps({"extrinsic": {"baseline": 0.2, "pitch": _num(rng, 0.03), "roll": 0.0, "yaw": _num(rng, 0.01), "x": 1.7, "y": 0.1, "z": _num(rng, 1.2)},
                                               "intrinsic": {"fx": _num(rng, f), "fy": _num(rng, f), "u0": _num(rng, cx), "v0": _num(rng, cy)}}))
    elif kind.startswith("kitti"):
        p2 = [_num(rng, f), 0, _num(rng, cx), _num(rng, 4.0), 0, _num(rng, f), _num(rng, cy), 0, 0, 0, 1, 0]
        files["--camera"] = ("calib.txt", ("P2: " + " ".join(str(v) for v in p2) + "\n").encode())
        if kind.endswith("plane"):
            plane = [_num(rng, 0.0, 0) if rng.random() < 0.9 else 1e308, -1.0, 0.0, _num(rng, 1.65)]
            files["--ground-plane"] = ("plane.txt", ("# Matrix\nWIDTH 4\nHEIGHT 1\n" + " ".join(str(v) for v in plane) + "\n").encode())
    if rng.random() < 0.2:
        pairs = [{"px": [_num(rng, u), _num(rng, v)], "ground": [_num(rng, x), _num(rng, y)]}
                 for u, v, x, y in ((10, 60, 5, 3), (86, 60, 5, -3), (30, 40, 20, 3), (66, 40, 20, -3), (48, 50, 10, 0))]
        pairs *= rng.choice([1, 1, 2, 2001])
        files["--ground-points"] = ("gp.json", _dumps({"pairs": pairs}))
    if rng.random() < 0.15:
        depth = np.full((H, W), rng.choice([10.0, 10.0, 1e30, -1.0, float("nan"), 0.0]), np.float32)
        path = folder / "depth.npy"
        np.save(path, depth)
        path.write_bytes(_mutate(rng, path.read_bytes()))
        args += ["--depth-map", str(path)]
    for option, (name, data) in files.items():
        (folder / name).write_bytes(data)
        args += [option, str(folder / name)]
    if rng.random() < 0.2:
        args += ["--max-range", str(rng.choice([80, 1e308, "inf", "nan", -5, 0, 1000, 1001, "1e3"]))]
    return args


def _digest(folder: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        h.update(str(p.relative_to(folder)).encode())
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("n", type=int, help="number of builds")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--timeout", type=float, default=10.0, help="seconds before a build counts as a hang")
    ap.add_argument("--keep", type=Path, help="keep the cases here (default: a temporary folder)")
    ns = ap.parse_args()
    rng = random.Random(ns.seed)
    outcomes: Counter[str] = Counter()
    examples: dict[str, list[str]] = {}
    changed = 0
    with tempfile.TemporaryDirectory() as tmp:
        root = ns.keep or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        world = root / "world"
        base = root / "base"
        base.mkdir(exist_ok=True)
        seed_args = _case(random.Random(-1), base)
        seed_args = [a for i, a in enumerate(seed_args) if not (a == "--max-range" or (i and seed_args[i - 1] == "--max-range"))]
        cmd = [sys.executable, "-m", "usdworld", "build", str(base / "img.png"), "-o", str(world)]
        subprocess.run(cmd, capture_output=True, timeout=120, check=False)
        if not (world / "world.usda").is_file():  # the seed case may itself be refused: build a plain one
            cv2.imwrite(str(base / "img.png"), np.full((H, W, 3), 90, np.uint8))
            cv2.imwrite(str(base / "road.png"), np.full((H, W), 7, np.uint8))  # all road: a photo alone is refused
            plain = cmd[:5] + ["--labels", str(base / "road.png"), "-o", str(world)]
            subprocess.run(plain, capture_output=True, timeout=120, check=True)
        before = _digest(world)
        for i in range(ns.n):
            folder = root / f"case{i:04d}"
            folder.mkdir(exist_ok=True)
            args = _case(rng, folder)
            cmd = [sys.executable, "-m", "usdworld", "build", str(folder / "img.png"), "-o", str(world), *args]
            try:
                r = subprocess.run(cmd, capture_output=True, text=True, timeout=ns.timeout, check=False)
            except subprocess.TimeoutExpired:
                outcome, detail = "hang", ""
            else:
                lines = r.stderr.strip().splitlines()
                if r.returncode == 0:
                    outcome, detail = "success", ""
                elif r.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: "):
                    outcome, detail = "clean error", lines[0]
                elif r.returncode in (1, 2):
                    outcome, detail = "internal error", r.stderr.strip()[-400:]
                else:
                    outcome, detail = "crash", f"return code {r.returncode}: {r.stderr.strip()[-300:]}"
            outcomes[outcome] += 1
            examples.setdefault(outcome, []).append(f"case{i:04d}: {' '.join(args)}\n    {detail}")
            if outcome == "success":
                before = _digest(world)  # the world legitimately changed
            elif _digest(world) != before:
                changed += 1
                examples.setdefault("world changed", []).append(f"case{i:04d}")
                before = _digest(world)
    print(f"{'outcome':<16}{'builds':>8}")
    for outcome in ("clean error", "success", "internal error", "crash", "hang"):
        print(f"{outcome:<16}{outcomes[outcome]:>8}")
    print(f"{'world changed':<16}{changed:>8}  (existing world folder altered by a failed build)")
    for outcome in ("internal error", "crash", "hang", "world changed"):
        for example in examples.get(outcome, [])[:SHOWN]:
            print(f"{outcome}: {example}")
    bad = outcomes["internal error"] + outcomes["crash"] + outcomes["hang"] + changed
    return 1 if bad else 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONWARNINGS", "default")
    sys.exit(main())
