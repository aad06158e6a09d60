"""Validate what a world owns; trust the assets whose cards record a clean validation.

A library asset is validated once, when the library is built, and its card records the
outcome with a digest of its files (:mod:`usdworld.authoring.asset_cards`). When a world (or
an export of it) is validated, an asset layer is *trusted* when:

* the files beside it that make up the asset (``<class>.usda`` and its ``<class>.*``
  siblings, read from the same folder or the same folder of a ``.usdz``) hash to the
  digest of a card in ``cards_dir``, so the card speaks of exactly these bytes, and
* that card records 0 errors for every validator that runs now, at the same version and
  with the same rules (:func:`usdworld.authoring.validate.validator_ids`).

A missing, stale or unclean card means the asset is validated like everything else.

What is validated every time: the stage as a whole (stage metadata, composition, the
package), every layer that is not trusted (the root, edits and base layers, the ground) and
every prim except those composed only from trusted layers. Below a prim that references a
trusted asset, the subtree is skipped when the world's own layers author nothing under it;
the prim itself, which carries the world's opinions (placement, variant selection,
provenance), is validated with the world's variant selection (the asset's other variants
were validated with the asset).
"""

from __future__ import annotations

import json
import logging
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

from pxr import Ar, Sdf, Usd, UsdValidation

from usdworld.authoring.asset_cards import CARD_SUFFIX, clean_validators, files_digest, member_names
from usdworld.authoring.validate import (
    ValidationIssue,
    _omni_issues,
    _usd_errors,
    omni_engine,
    usd_validators,
)

log = logging.getLogger(__name__)


def card_digests(cards_dir: Path) -> dict[str, frozenset[str]]:
    """digest -> ids of the validators its card records as clean, for every card in ``cards_dir``."""
    found: dict[str, frozenset[str]] = {}
    if not cards_dir.is_dir():
        return found
    for path in sorted(cards_dir.glob(f"*{CARD_SUFFIX}")):
        try:
            card = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if isinstance(card, dict) and isinstance(card.get("digest"), str):
            found[card["digest"]] = clean_validators(card)
    return found


class _Siblings:
    """Names and bytes of the files beside a layer, on disk or inside a ``.usdz``."""

    def __init__(self) -> None:
        self._zips: dict[str, zipfile.ZipFile] = {}

    def close(self) -> None:
        for zf in self._zips.values():
            zf.close()

    def of(self, layer: Sdf.Layer) -> tuple[str, str, dict[str, Any]] | None:
        """(its folder, the layer's file name, name -> loader of the bytes of every file in the folder)."""
        identifier = layer.identifier
        if Ar.IsPackageRelativePath(identifier):
            package, inner = Ar.SplitPackageRelativePathOuter(identifier)
            if Ar.IsPackageRelativePath(inner) or not package.endswith(".usdz"):
                return None  # a package inside a package: never trusted
            zf = self._zips.get(package)
            if zf is None:
                zf = self._zips[package] = zipfile.ZipFile(package)
            folder = PurePosixPath(inner).parent
            members = {
                PurePosixPath(n).name: (lambda n=n: zf.read(n))
                for n in zf.namelist()
                if PurePosixPath(n).parent == folder
            }
            return f"{package}[{folder}]", PurePosixPath(inner).name, members
        if not layer.realPath:
            return None
        path = Path(layer.realPath)
        return (
            str(path.parent),
            path.name,
            {p.name: p.read_bytes for p in path.parent.iterdir() if p.is_file()},
        )


def trusted_layers(stage: Usd.Stage, cards_dir: Path, needed: frozenset[str]) -> dict[str, str]:
    """The stage's layers that belong to an asset with a current, clean card.

    Args:
        stage: the stage to validate.
        cards_dir: folder of the cards that may vouch for assets (a world's ``assets/``).
        needed: ids of the validators that will run; a card must record each as clean.

    Returns:
        layer identifier -> the asset's root layer name, for every trusted layer.
    """
    digests = {d: ok for d, ok in card_digests(cards_dir).items() if needed <= ok}
    if not digests:
        return {}
    own = {layer.identifier for layer in stage.GetLayerStack(includeSessionLayers=True)}
    used = [layer for layer in stage.GetUsedLayers() if layer.identifier not in own]
    siblings = _Siblings()
    trusted: dict[str, str] = {}
    try:
        groups: dict[tuple[str, str], list[str]] = {}
        for layer in used:
            found = siblings.of(layer)
            if found is None:
                continue
            where, name, files = found
            stem = name.split(".", 1)[0]
            key = (where, stem)
            if key not in groups:
                names = member_names(stem, files)
                vouched = f"{stem}.usda" in names and files_digest((n, files[n]()) for n in names) in digests
                groups[key] = names if vouched else []
            if name in groups[key]:
                trusted[layer.identifier] = f"{stem}.usda"
    finally:
        siblings.close()
    return trusted


@dataclass(frozen=True)
class Scope:
    """Which prims and layers of a stage are validated.

    Attributes:
        trusted: identifiers of trusted asset layers (:func:`trusted_layers`).
        root_stack: identifiers of the stage's root layer stack (root, edits, base, session).
        owned_below: prim paths under which the root layer stack authors a prim spec.
    """

    trusted: frozenset[str]
    root_stack: frozenset[str]
    owned_below: frozenset[str]

    @classmethod
    def of(cls, stage: Usd.Stage, trusted: frozenset[str]) -> Scope:
        """The scope of ``stage`` with the given trusted layers."""
        stack = stage.GetLayerStack(includeSessionLayers=True)
        below: set[str] = set()

        def visit(path: Sdf.Path) -> None:
            if path.IsPrimPath() or path.IsPrimVariantSelectionPath():
                for ancestor in path.StripAllVariantSelections().GetAncestorsRange():
                    if ancestor != path.StripAllVariantSelections():
                        below.add(str(ancestor))

        for layer in stack:
            layer.Traverse(Sdf.Path.absoluteRootPath, visit)
        return cls(trusted, frozenset(layer.identifier for layer in stack), frozenset(below))

    def classify(self, prim: Usd.Prim) -> tuple[bool, bool]:
        """(validate this prim, descend into its children)."""
        if not self.trusted:
            return True, True
        specs = prim.GetPrimStack()
        layers = {spec.layer.identifier for spec in specs}
        if not layers & self.trusted:
            return True, True
        if layers - self.trusted - self.root_stack:
            return True, True  # also composed from a layer nobody vouched for
        path = prim.GetPath()
        if any(
            spec.layer.identifier in self.root_stack and spec.path.StripAllVariantSelections() != path
            for spec in specs
        ):
            return True, True  # the world's layers bring in other prims of their own (internal arcs)
        return bool(layers & self.root_stack), str(path) in self.owned_below


@dataclass
class ScopedValidation:
    """Issues and counts of a scoped validation.

    Attributes:
        issues: every issue found.
        trusted_assets: root layer names of the assets trusted (not validated again).
        layers_checked: layers validated (UsdValidation's layer validators).
        layers_skipped: trusted layers.
        prims_checked: prims UsdValidation's prim validators ran on.
        subtrees_skipped: prims whose (trusted) children were not visited.
    """

    issues: list[ValidationIssue] = field(default_factory=list)
    trusted_assets: tuple[str, ...] = ()
    layers_checked: int = 0
    layers_skipped: int = 0
    prims_checked: int = 0
    subtrees_skipped: int = 0


def scoped_prims(stage: Usd.Stage, scope: Scope) -> tuple[list[Usd.Prim], int]:
    """The prims to validate (instance proxies included) and the number of subtrees skipped."""
    prims, pruned = [], 0
    it = iter(Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()))
    for prim in it:
        check, descend = scope.classify(prim)
        if check:
            prims.append(prim)
        if not descend:
            it.PruneChildren()
            pruned += 1
    return prims, pruned


def usd_issues_scoped(stage: Usd.Stage, scope: Scope, result: ScopedValidation) -> None:
    """UsdValidation on the stage, the untrusted layers and the prims in scope (adds to ``result``)."""
    validators = usd_validators()
    errors: list[UsdValidation.ValidationError] = []
    for validator in validators:  # stage tasks only: metadata, composition errors, packages
        errors.extend(validator.Validate(stage))
    context = UsdValidation.ValidationContext(validators)
    for layer in stage.GetUsedLayers():
        if layer.identifier in scope.trusted:
            result.layers_skipped += 1
        else:
            result.layers_checked += 1
            errors.extend(context.Validate(layer))
    prims, pruned = scoped_prims(stage, scope)
    errors.extend(context.Validate(prims))
    result.prims_checked, result.subtrees_skipped = len(prims), pruned
    result.issues.extend(_usd_errors(errors))


def _scoped_engine_class(scope: Scope) -> type | None:
    """An omni ``ValidationEngine`` whose checker leaves out what ``scope`` trusts, or None.

    Built on omni-asset-validator's compliance checker internals (1.18); where they differ,
    None, and the caller validates everything.
    """
    from omni.asset_validator import ValidationEngine
    from omni.asset_validator._compliance_checker import ComplianceChecker
    from omni.asset_validator._compliance_runners import ComplianceCheckerEvent, ComplianceCheckerEventType

    kinds = ComplianceCheckerEventType
    hooks = (
        hasattr(ComplianceChecker, "_check_compliance")
        and hasattr(ComplianceChecker, "_traverse_range")
        and hasattr(ValidationEngine, "_create_compliance_checker")
        and hasattr(kinds, "LAYER")
        and hasattr(kinds, "PRIM")
    )
    if not hooks:
        log.info("omni-asset-validator's checker is not the one known; validating every asset")
        return None

    class ScopedChecker(ComplianceChecker):  # type: ignore[misc, valid-type]
        def _check_compliance(self, asset: Any, asset_dependencies: Any = None) -> Iterator[Any]:
            for event in super()._check_compliance(asset, asset_dependencies):
                if event.type is kinds.LAYER and event.args[0].identifier in scope.trusted:
                    continue
                yield event

        def _traverse_range(self, primRangeIt: Any, isStageRoot: bool) -> Iterator[Any]:
            # omni's traversal, with the prims and subtrees the scope trusts left out
            with_variants = []
            root_prim = primRangeIt.GetCurrentPrim()
            for prim in primRangeIt:
                check, descend = scope.classify(prim)
                if not descend:
                    primRangeIt.PruneChildren()
                    if check:
                        yield ComplianceCheckerEvent(kinds.PRIM, prim)
                    continue
                plain = not self._doVariants or (not isStageRoot and prim == root_prim)
                if plain or not prim.GetVariantSets().GetNames():
                    if check:
                        yield ComplianceCheckerEvent(kinds.PRIM, prim)
                else:
                    with_variants.append(prim)
                    primRangeIt.PruneChildren()
            yield ComplianceCheckerEvent(kinds.FLUSH, None)
            for prim in with_variants:
                yield from self._traverse_variants(prim)

    class ScopedEngine(ValidationEngine):  # type: ignore[misc, valid-type]
        def _create_compliance_checker(self) -> Any:
            checker = ScopedChecker(
                stats=self.stats,
                skip_variants=not self.variants,
                parameters=self.parameters,
                resolver=self._resolver,
            )
            for rule in self.rules:
                checker.AddRule(rule)
            return checker

    return ScopedEngine


def validate_scoped(
    path: Path, stage: Usd.Stage, cards_dir: Path | None, validators: dict[str, str]
) -> ScopedValidation:
    """Validate a stage's own layers and prims, trusting assets with clean cards in ``cards_dir``.

    Args:
        path: the stage's root file (omni-asset-validator opens it itself).
        stage: the stage opened from ``path``.
        cards_dir: folder of the cards that may vouch for assets (None: trust nothing).
        validators: the validators to run (:func:`usdworld.authoring.validate.validator_ids`).

    Returns:
        The issues, the assets trusted and what was checked.
    """
    trusted = trusted_layers(stage, cards_dir, frozenset(validators.values())) if cards_dir else {}
    scope = Scope.of(stage, frozenset(trusted))
    result = ScopedValidation(trusted_assets=tuple(sorted(set(trusted.values()))))
    usd_issues_scoped(stage, scope, result)
    if "omni" in validators:
        engine_class = _scoped_engine_class(scope) if trusted else None
        result.issues.extend(_omni_issues(path, omni_engine(engine_class)))
    return result
