"""Asset cards: what an asset's USD files say about it, read once and kept beside it as JSON.

Every build and every edit needs each class asset's variants, sizes and shape measures
(:mod:`usdworld.authoring.asset_measures`). Reading them means opening the asset's stage,
composing every variant's meshes and rasterising a side view: about 0.2 s per process for
the classes of one street, which a one-second command cannot afford. A card,
``<class>.card.json`` beside ``<class>.usda``, keeps the result:

* ``digest``: SHA-256 over the asset's files (``<class>.usda`` and every other
  ``<class>.*`` file in its folder except the card, in name order, each name and its bytes):
  a card whose digest does not match the files is stale and ignored, so a card can never
  give another file version's numbers;
* ``variants``, ``default_variant``, ``size_by_variant``: :class:`~usdworld.authoring.asset_library.AssetInfo`;
* ``measures``: variant -> :class:`~usdworld.authoring.asset_measures.VariantMeasures` fields;
* ``validation`` (when the writer validated the asset): validator id (name, version and
  rules, :func:`usdworld.authoring.validate.validator_ids`) -> number of errors it found in
  these files, every variant included. An export does not validate again an asset whose card
  matches the exported bytes and records 0 errors for every validator it runs
  (:mod:`usdworld.authoring.validation_scope`).

Floats are written as Python's shortest round-trip repr, so a card gives exactly the numbers
measuring the files gives: worlds are byte-identical with and without cards.

Who writes cards: ``tools/make_assets.py`` for the built-in library, ``usdworld assets add``
for a user library, and world building, which copies a valid card with its asset into the
world's ``assets/`` folder (so the editor reads the world's assets without measuring them).
Reading never writes: a library without cards still works, measured in each process.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from usdworld.atomic import write_text_atomic

#: File name suffix of a card: ``<class>.card.json``.
CARD_SUFFIX = ".card.json"
#: Layout version of the card; a card of another version is ignored (2: measures hold
#: ``contact_offset``).
CARD_VERSION = 2


def card_path(usda: Path) -> Path:
    """The card beside an asset's root layer (``car.usda`` -> ``car.card.json``)."""
    return usda.with_name(usda.stem + CARD_SUFFIX)


def asset_files(usda: Path) -> list[Path]:
    """The files a card's digest covers: ``<class>.usda`` and its ``<class>.*`` siblings, by name."""
    files = {p.name: p for p in usda.parent.iterdir() if p.is_file()}
    return [files[n] for n in member_names(usda.stem, files)]


def member_names(stem: str, names: Iterable[str]) -> list[str]:
    """The names among ``names`` a card's digest covers for asset ``stem``: ``<stem>.*`` but cards, sorted."""
    prefix = stem + "."
    return sorted(n for n in names if n.startswith(prefix) and not n.endswith(CARD_SUFFIX))


def files_digest(files: Iterable[tuple[str, bytes]]) -> str:
    """SHA-256 (hex) over (file name, bytes) pairs, in the order given (see :func:`asset_digest`)."""
    h = hashlib.sha256()
    for name_text, data in files:
        name = name_text.encode()
        h.update(len(name).to_bytes(8, "little") + name + len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()


def asset_digest(usda: Path) -> str:
    """SHA-256 (hex) over the asset's files' names and bytes (:func:`asset_files`)."""
    return files_digest((path.name, path.read_bytes()) for path in asset_files(usda))


def read_card(usda: Path) -> dict[str, Any] | None:
    """The card of an asset when it exists, is readable and matches the files; else None.

    Args:
        usda: the asset's root layer (``<class>.usda``).

    Returns:
        The card's fields (see the module docstring), or None when there is no current card.
    """
    path = card_path(usda)
    try:
        card = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(card, dict) or card.get("version") != CARD_VERSION:
        return None
    try:
        if card.get("digest") != asset_digest(usda):
            return None
    except OSError:
        return None
    return card


def card_text(digest: str, info: Any, measures: dict[str, Any], validation: dict[str, int] | None = None) -> str:
    """A card's JSON text.

    Args:
        digest: :func:`asset_digest` of the files measured.
        info: the asset's ``AssetInfo``.
        measures: variant ('' for an asset without variants) -> ``VariantMeasures``.
        validation: validator id -> errors it found in the same files; None when not validated.
    """
    card: dict[str, Any] = {
        "version": CARD_VERSION,
        "digest": digest,
        "variants": list(info.variants),
        "default_variant": info.default_variant,
        "size_by_variant": {v: list(s) for v, s in info.size_by_variant.items()},
        "measures": {
            v: {
                "contact_half": list(m.contact_half),
                "contact_mean_reach": m.contact_mean_reach,
                "top_half": list(m.top_half),
                "top_shape": m.top_shape,
                "contact_offset": list(m.contact_offset),
            }
            for v, m in measures.items()
        },
    }
    if validation is not None:
        card["validation"] = dict(validation)
    return json.dumps(card, indent=1, sort_keys=True) + "\n"


def clean_validators(card: dict[str, Any]) -> frozenset[str]:
    """Ids of the validators a card records as having found no error in its asset."""
    record = card.get("validation")
    if not isinstance(record, dict):
        return frozenset()
    return frozenset(k for k, v in record.items() if isinstance(k, str) and v == 0 and not isinstance(v, bool))


def write_card(usda: Path, text: str) -> Path:
    """Write a card's text (:func:`card_text`) beside its asset, atomically; returns its path."""
    path = card_path(usda)
    write_text_atomic(path, text)
    return path
