"""Run every ``pxr.UsdValidation`` validator and, when installed, omni-asset-validator.

The omni validator runs its default rules plus the requirements UN.006 (``upAxis = Z``)
and UN.007 (``metersPerUnit = 1``), which is what Omniverse / SimReady asks of a world.

Assets are validated once, when a library is built (:func:`validate_asset`, every variant),
and the outcome goes into their cards (:func:`validation_record`); exports then validate
only what the world owns (:mod:`usdworld.authoring.validation_scope`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from pxr import Sdf, Tf, Usd, UsdValidation

from usdworld.authoring.stages import open_stage
from usdworld.errors import InputError
from usdworld.io.images import native_stderr_captured

#: Requirements enabled on top of omni-asset-validator's default rules.
OMNI_REQUIREMENTS = ("UN.006", "UN.007")


@dataclass(frozen=True)
class ValidationIssue:
    """One problem a validator found.

    Attributes:
        validator: ``usd`` or ``omni``.
        rule: rule or validator name.
        severity: ``error`` or ``warning``.
        message: what is wrong, as the validator said it.
        at: prim path or layer the issue is about ('' when the stage as a whole).
    """

    validator: str
    rule: str
    severity: str
    message: str
    at: str = ""


@dataclass(frozen=True)
class FileProblem:
    """A file a layer needs that is missing or does not open.

    Attributes:
        path: the absolute path of the file.
        kind: ``missing`` or ``broken`` (present but not a readable USD layer).
        needed_by: the layer that names it (sublayer, reference or payload).
        reason: why it does not open ('' when missing).
    """

    path: str
    kind: str
    needed_by: str
    reason: str = ""


def file_problems(path: str | Path) -> list[FileProblem]:
    """The missing and broken files among a layer's composition dependencies (recursively).

    Walks sublayers, references and payloads from ``path``; each file is opened once.
    Anonymous and unresolvable-by-design paths (search paths) count as missing.

    Args:
        path: the root layer (``world.usda`` or an asset).

    Returns:
        The problems in the order met (breadth first from the root), each file once.
    """
    root = str(Path(path).resolve())
    queue, seen, problems = [(root, "")], {root}, []
    while queue:
        current, needed_by = queue.pop(0)
        try:
            layer = Sdf.Layer.FindOrOpen(current)
        except Tf.ErrorException as exc:  # the file exists but is not a readable layer
            problems.append(FileProblem(current, "broken", needed_by, str(exc).strip().splitlines()[-1]))
            continue
        if layer is None:
            problems.append(FileProblem(current, "missing" if not Path(current).exists() else "broken", needed_by))
            continue
        for dependency in layer.GetCompositionAssetDependencies():
            target = str(Path(layer.ComputeAbsolutePath(dependency)).resolve()) if dependency else ""
            if not target or target in seen:
                continue
            seen.add(target)
            if not Path(target).is_file():
                problems.append(FileProblem(target, "missing", current))
            else:
                queue.append((target, current))
    return problems


def _at_text(at: object) -> str:
    """Where an omni-asset-validator issue is: a prim or property path, else a layer."""
    if at is None:
        return ""
    prim_id = getattr(at, "prim_id", None)
    path = getattr(at, "path", None) or getattr(prim_id, "path", None)
    if path is not None and str(path):
        return str(path)
    layer = getattr(at, "identifier", None) or getattr(getattr(at, "root_layer", None), "identifier", None)
    return str(layer) if layer else str(at)


def omni_validator_available() -> bool:
    """True when omni-asset-validator can be imported."""
    for noisy in ("omni.asset_validator", "omni.asset_validator._plugins"):
        logging.getLogger(noisy).setLevel(logging.WARNING)
    try:
        import omni.asset_validator  # noqa: F401
    except ImportError:
        return False
    return True


def validator_ids(*, omni: bool = True) -> dict[str, str]:
    """The validators that run here, by short name (``usd``, ``omni``), as versioned ids.

    An id names the validator, its version and the rules enabled, so a card's record of a
    clean asset (:func:`validation_record`) only counts for the same validator.

    Args:
        omni: include omni-asset-validator (when it is installed).
    """
    ids = {"usd": "UsdValidation usd-core " + ".".join(str(n) for n in Usd.GetVersion())}
    if omni and omni_validator_available():
        from omni.asset_validator import __version__ as omni_version

        ids["omni"] = f"omni-asset-validator {omni_version} default rules + {' + '.join(OMNI_REQUIREMENTS)}"
    return ids


def _usd_errors(errors: list[UsdValidation.ValidationError]) -> list[ValidationIssue]:
    issues = []
    for err in errors:
        kind = err.GetType()
        if kind == UsdValidation.ValidationErrorType.None_:
            continue
        severity = "error" if kind == UsdValidation.ValidationErrorType.Error else "warning"
        sites = [str(s.GetPrim().GetPath()) for s in err.GetSites() if s.IsPrim()]
        validator = err.GetValidator()
        name = validator.GetMetadata().name if validator else "usdValidation"
        issues.append(ValidationIssue("usd", name, severity, err.GetMessage(), sites[0] if sites else ""))
    return issues


def usd_validators() -> list[UsdValidation.Validator]:
    """Every validator of ``pxr.UsdValidation``."""
    return list(UsdValidation.ValidationRegistry().GetOrLoadAllValidators())


def _usd_issues(stage: Usd.Stage) -> list[ValidationIssue]:
    return _usd_errors(UsdValidation.ValidationContext(usd_validators()).Validate(stage))


def omni_engine(engine_class: type | None = None) -> object:
    """An omni-asset-validator engine with the default rules and :data:`OMNI_REQUIREMENTS`.

    Args:
        engine_class: a ``ValidationEngine`` subclass to build (default the engine itself).
    """
    from omni.asset_validator import ValidationEngine
    from omni.asset_validator._requirements import RequirementsRegistry

    engine = (engine_class or ValidationEngine)()
    registry = RequirementsRegistry()
    for code in OMNI_REQUIREMENTS:
        requirement = registry.find(code, None)
        if requirement is not None:
            engine.enable_requirement(requirement)
    return engine


def _omni_issues(path: Path, engine: object | None = None) -> list[ValidationIssue]:
    from omni.asset_validator import IssueSeverity

    issues = []
    for issue in (engine or omni_engine()).validate(str(path)).issues():  # type: ignore[attr-defined]
        if issue.severity in (IssueSeverity.ERROR, IssueSeverity.FAILURE):
            severity = "error"
        elif issue.severity == IssueSeverity.WARNING:
            severity = "warning"
        else:
            continue
        rule = getattr(issue.rule, "__name__", str(issue.rule))
        issues.append(ValidationIssue("omni", rule, severity, str(issue.message), _at_text(issue.at)))
    return issues


def validate_file(path: str | Path, *, omni: bool = True) -> list[ValidationIssue]:
    """Validate one USD file with every available validator.

    Args:
        path: a ``.usda``/``.usdc``/``.usdz`` file.
        omni: also run omni-asset-validator when it is installed.

    Returns:
        Every issue found (errors and warnings); empty when the file is clean.

    Raises:
        InputError: the file does not exist or does not open as a USD stage.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such USD file; pass the world's .usda path (e.g. OUT/world.usda)")
    # USD also prints what the validators report (a sublayer it could not load, say) straight
    # to the process's stderr; the issues carry it, so the duplicate goes to the debug log
    with native_stderr_captured(str(path)):
        stage = open_stage(path, whole=False)  # missing sublayers are findings
        issues = _usd_issues(stage)
        if omni and omni_validator_available():
            issues.extend(_omni_issues(path))
    return issues


def validate_asset(usda: str | Path, *, omni: bool = True) -> list[ValidationIssue]:
    """Validate a library asset as its card records it: every variant, every validator.

    omni-asset-validator visits every variant itself; UsdValidation sees the composed stage
    only, so it runs once per selection of the root prim's variant sets.

    Args:
        usda: the asset's root layer.
        omni: also run omni-asset-validator when it is installed.

    Returns:
        Every distinct issue found, in the order found.

    Raises:
        InputError: the file does not exist or does not open as a USD stage.
    """
    path = Path(usda)
    if not path.is_file():
        raise InputError(f"{path}: no such asset file")
    issues: list[ValidationIssue] = []
    with native_stderr_captured(str(path)):
        stage = open_stage(path, whole=False)  # missing sublayers are findings
        context = UsdValidation.ValidationContext(usd_validators())
        root = stage.GetDefaultPrim() or stage.GetPseudoRoot()
        sets = root.GetVariantSets()
        selections: list[dict[str, str]] = [{}]
        for set_name in sets.GetNames():
            names = sets.GetVariantSet(set_name).GetVariantNames()
            selections = [{**s, set_name: v} for s in selections for v in names] or selections
        for selection in selections:
            with Usd.EditContext(stage, stage.GetSessionLayer()):
                for set_name, variant in selection.items():
                    sets.GetVariantSet(set_name).SetVariantSelection(variant)
            issues.extend(i for i in _usd_errors(context.Validate(stage)) if i not in issues)
        if omni and omni_validator_available():
            issues.extend(_omni_issues(path))
    return issues


def validation_record(issues: list[ValidationIssue], *, omni: bool = True) -> dict[str, int]:
    """What a card keeps of a validation: validator id -> number of errors it found.

    Args:
        issues: what :func:`validate_asset` returned.
        omni: whether omni-asset-validator was asked for (it counts only where installed).
    """
    return {
        vid: sum(1 for i in issues if i.validator == short and i.severity == "error")
        for short, vid in validator_ids(omni=omni).items()
    }


def errors_only(issues: list[ValidationIssue]) -> list[ValidationIssue]:
    """The issues of severity ``error``."""
    return [i for i in issues if i.severity == "error"]
