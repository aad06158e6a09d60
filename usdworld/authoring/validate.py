"""Run every ``pxr.UsdValidation`` validator and, when installed, omni-asset-validator.

The omni validator runs its default rules plus the requirements UN.006 (``upAxis = Z``)
and UN.007 (``metersPerUnit = 1``), which is what Omniverse / SimReady asks of a world.
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


def _usd_issues(stage: Usd.Stage) -> list[ValidationIssue]:
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    issues = []
    for err in UsdValidation.ValidationContext(validators).Validate(stage):
        kind = err.GetType()
        if kind == UsdValidation.ValidationErrorType.None_:
            continue
        severity = "error" if kind == UsdValidation.ValidationErrorType.Error else "warning"
        sites = [str(s.GetPrim().GetPath()) for s in err.GetSites() if s.IsPrim()]
        validator = err.GetValidator()
        name = validator.GetMetadata().name if validator else "usdValidation"
        issues.append(ValidationIssue("usd", name, severity, err.GetMessage(), sites[0] if sites else ""))
    return issues


def _omni_issues(path: Path) -> list[ValidationIssue]:
    from omni.asset_validator import IssueSeverity, ValidationEngine
    from omni.asset_validator._requirements import RequirementsRegistry

    engine = ValidationEngine()
    registry = RequirementsRegistry()
    for code in OMNI_REQUIREMENTS:
        requirement = registry.find(code, None)
        if requirement is not None:
            engine.enable_requirement(requirement)
    issues = []
    for issue in engine.validate(str(path)).issues():
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
        stage = open_stage(path)
        issues = _usd_issues(stage)
        if omni and omni_validator_available():
            issues.extend(_omni_issues(path))
    return issues


def errors_only(issues: list[ValidationIssue]) -> list[ValidationIssue]:
    """The issues of severity ``error``."""
    return [i for i in issues if i.severity == "error"]
