"""The choice of the variant an image shows, by the variants' sizes and shapes (:class:`usdworld.io.asset_catalogue.AssetSizes`)."""

from __future__ import annotations

import numpy as np

from usdworld.io.asset_catalogue import AssetSizes


def choose_variant(
    sizes: AssetSizes,
    measured_h: float,
    aspect: float,
    yaw_to_ray: float,
    top_shape: float | None,
    top_shape_offset: float,
) -> str:
    """The variant whose height, silhouette aspect and top shape best match the image.

    Args:
        sizes: the class's variants.
        measured_h: metric height seen in the image (NaN when cut).
        aspect: the mask's width / height in pixels (NaN when cut).
        yaw_to_ray: object yaw minus the viewing ray's bearing, radians.
        top_shape: the mask's :func:`usdworld.perception.shape.top_shape_ratio` (None when
            not usable); compared with the variants' side views.
        top_shape_offset: added to both top-shape ratios before their log ratio
            (``PlacementParams.top_shape_offset``), so that near-zero ratios (round tops)
            compare on a sane scale.

    Returns:
        The variant name; the default variant when nothing is measured or there is one.
    """
    shape_usable = top_shape is not None and len(sizes.top_shape_by_variant) == len(sizes.by_variant)
    if len(sizes.by_variant) < 2 or not (np.isfinite(measured_h) or np.isfinite(aspect) or shape_usable):
        return sizes.default_variant
    names = sorted(sizes.by_variant)
    errs = []
    for n in names:
        l, w, h = sizes.by_variant[n]
        err = abs(np.log(measured_h / h)) if np.isfinite(measured_h) else 0.0
        if np.isfinite(aspect) and aspect > 0:
            across = abs(l * np.sin(yaw_to_ray)) + abs(w * np.cos(yaw_to_ray))
            err += abs(np.log(aspect / (across / h)))
        if shape_usable:
            err += abs(
                np.log((top_shape + top_shape_offset) / (sizes.top_shape_by_variant[n] + top_shape_offset))
            )
        errs.append(err)
    return names[int(np.argmin(errs))]
