"""Options shared by the commands that score a world against ground truth (evaluate, report)."""

from __future__ import annotations

import typer

GT = typer.Option(None, "--gt", help="3D ground truth: synth *_gt.json, KITTI label_2 .txt or nuScenes info JSON.")
CALIB = typer.Option(None, "--calib", help="KITTI calib file for --gt label_2 (default: ../calib/<same name>).")
NUSCENES_CAMERA = typer.Option("CAM_FRONT", "--nuscenes-camera", help="Camera of a nuScenes info file.")
