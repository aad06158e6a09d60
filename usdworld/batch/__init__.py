"""``usdworld batch``: build whole datasets, on one machine or on a Dask cluster.

Each frame is built into ``OUT/<frame_id>/`` by :func:`usdworld.pipeline.build`, exactly as
``usdworld build`` would; ``OUT/batch.json`` records every frame and ``OUT/index.usda``
places every built world side by side as a payload.

One machine
-----------
::

    usdworld batch cityscapes/ --layout cityscapes -o worlds/              # all splits, 1 worker
    usdworld batch cityscapes/ --layout cityscapes --split val -o worlds/ --workers 8
    usdworld batch kitti/object/training --layout kitti -o worlds/ --workers 2
    usdworld batch kitti/object/training --layout kitti --ground-plane -o worlds/
    usdworld batch frames.json -o worlds/                                   # a manifest (.json or .csv)
    usdworld batch rigs/ --layout views -o worlds/                          # a world per views manifest
    usdworld batch infos.json --layout nuscenes -o worlds/                  # a world per nuScenes sample

``--workers 1`` (the default) builds in the calling process, one frame after another;
``--workers N`` runs a local pool of N worker processes (``spawn``), one frame per process
at a time. Use about one worker per CPU core; memory per worker stays flat over a batch
(a few hundred MiB at 2048 x 1024). A frame that fails is recorded with its error and the
batch goes on (``--fail-fast`` stops at the first); the exit code is 1 when any frame
failed, 2 for bad arguments. ``--resume`` skips every frame whose world is complete and
whose inputs and options hash to the same key as last time, so an interrupted or partly
failed batch is finished by running the same command again with ``--resume``. Frames that
discovery cannot build (a missing label file, an unknown file name) are listed with the
reason on the terminal and in ``batch.json`` -> ``incomplete``; nothing is guessed.

A Dask cluster
--------------
The same command runs on Dask (``pip install "dask[distributed]>=2026.8"``)::

    usdworld batch frames.json -o /shared/worlds --scheduler tcp://10.0.0.5:8786
    usdworld batch frames.json -o worlds/ --dask-local 4        # a LocalCluster for this run

The worker function (:func:`usdworld.batch.worker.run_frame`) is pure and picklable: Dask
sends it a small task of paths, the worker imports usdworld itself, builds the frame and
sends back one record. So **workers need the same usdworld version and the same data
and output paths** as the machine that runs ``usdworld batch`` (a shared filesystem such
as NFS, mounted at the same place); both are checked when the batch starts. Start a
cluster by hand with ``dask scheduler`` on one machine and ``dask worker
tcp://HOST:8786 --nthreads 1 --nworkers N`` on each worker machine; on Kubernetes use
dask-kubernetes, on SLURM/PBS/SGE/LSF use dask-jobqueue, and pass the scheduler address
they give to ``--scheduler``.

Python API
----------
::

    from usdworld.batch import LocalPoolExecutor, check_failures, discover, run_batch

    with LocalPoolExecutor(workers=2) as executor:
        summary = run_batch(discover("cityscapes/", "cityscapes"), Path("worlds"), executor, resume=True)
    check_failures(summary)   # raises FramesFailed when any frame failed

Modules: :mod:`~usdworld.batch.discover` (layouts and manifests, streamed),
:mod:`~usdworld.batch.worker` (the worker function), :mod:`~usdworld.batch.executors`
(in process, local pool), :mod:`~usdworld.batch.dask_executor`,
:mod:`~usdworld.batch.resume` (keys), :mod:`~usdworld.batch.records` (``batch.json``),
:mod:`~usdworld.authoring.batch_index` (``index.usda``), :mod:`~usdworld.batch.progress`,
:mod:`~usdworld.batch.runner`, :mod:`~usdworld.batch.synthetic` (test and benchmark data).
"""

from __future__ import annotations

from usdworld.batch.dask_executor import DaskExecutor
from usdworld.batch.discover import LAYOUTS, discover, discover_cityscapes, discover_kitti, discover_manifest
from usdworld.batch.executors import InlineExecutor, LocalPoolExecutor
from usdworld.batch.frames import Frame, Incomplete
from usdworld.batch.records import BatchSummary, FrameRecord
from usdworld.batch.resume import frame_key
from usdworld.batch.runner import check_failures, run_batch
from usdworld.batch.worker import FrameTask, run_frame
from usdworld.errors import FramesFailed

__all__ = [
    "LAYOUTS",
    "BatchSummary",
    "DaskExecutor",
    "Frame",
    "FrameRecord",
    "FrameTask",
    "FramesFailed",
    "Incomplete",
    "InlineExecutor",
    "LocalPoolExecutor",
    "check_failures",
    "discover",
    "discover_cityscapes",
    "discover_kitti",
    "discover_manifest",
    "frame_key",
    "run_batch",
    "run_frame",
]
