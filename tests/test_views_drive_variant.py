"""A drive's standing trunk object takes the variant its frames' evidence favours, not its surest frame's alone."""

from __future__ import annotations

import dataclasses

import numpy as np
from layout_support import ground_placement

from usdworld.parameters.views import ViewsParams
from usdworld.perception.depth.fusion import DepthCue
from usdworld.views.drive import track_drive
from usdworld.views.fusion import Observation

POLE = (30.0, -5.0)
LAMP_OFFSET = np.array([-0.85, 0.0])  # a street lamp's mast from its footprint centre (its arm's middle)


def _pole(frame: int, variant: str, sigma_r: float) -> Observation:
    """The pole at POLE, its contact (the mast) seen from a camera at (2 frame, 0) as ``variant``."""
    camera = np.array([2.0 * frame, 0.0])
    cue = DepthCue("contact", float(np.linalg.norm(np.asarray(POLE) - camera)), sigma_r)
    placement = ground_placement("pole", POLE, (100, 40, 104, 160), (0.3, 0.3, 6.0), cues=(cue,))
    if variant == "street_lamp":
        placement = dataclasses.replace(
            placement, variant=variant, size_m=np.array([2.0, 0.3, 8.0]), contact_offset=LAMP_OFFSET
        ).with_contact_at(np.array([*POLE, 0.0]))
    else:
        placement = dataclasses.replace(placement, variant=variant)
    return Observation(frame, f"f{frame}", f"f{frame}.png", placement, camera, sigma_r, 0.05)


def _placed(variants: list[tuple[str, float]]):
    obs = [_pole(k, v, s) for k, (v, s) in enumerate(variants)]
    (pole,) = track_drive(obs, [0.1 * k for k in range(len(obs))], PARAMS)
    return pole.fused.placement


PARAMS = ViewsParams()


def test_the_variant_with_the_most_evidence_wins_over_the_surest_frame() -> None:
    """The surest frame (0.5 m) says street lamp, four frames of 0.8 m say plain pole (their summed weight
    4 / 0.64 = 6.25 against 4): the pole is plain, its footprint centre on its mast; taken as the lamp it
    would stand 0.85 m off, under the lamp's arm. Where the surest frame (0.3 m, weight 11.1) outweighs
    four plain frames of 1.0 m (weight 4), the object is a street lamp, its centre under its arm."""
    placed = _placed([("street_lamp", 0.5)] + [("plain", 0.8)] * 4)
    assert placed.variant == "plain"
    assert np.allclose(placed.contact_offset, 0.0)
    assert np.allclose(placed.position_world[:2], POLE, atol=0.05)
    lamp = _placed([("street_lamp", 0.3)] + [("plain", 1.0)] * 4)
    assert lamp.variant == "street_lamp"
    mast = lamp.contact_world[:2]
    assert np.allclose(mast, POLE, atol=0.05)
    assert np.isclose(float(np.linalg.norm(lamp.position_world[:2] - mast)), 0.85, atol=1e-6)
