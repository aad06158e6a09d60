"""Run every ``pxr.UsdValidation`` validator and, when installed, omni-asset-validator.

The omni validator runs its default rules plus the requirements UN.006 (``upAxis = Z``)
and UN.007 (``metersPerUnit = 1``), which is what Omniverse / SimReady asks of a world.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from pxr import Usd, UsdValidation

from usdworld.authoring.stages import open_stage
from usdworld.errors import InputError

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
        at = str(issue.at) if issue.at is not None else ""
        issues.append(ValidationIssue("omni", rule, severity, str(issue.message), at))
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
    stage = open_stage(path)
    issues = _usd_issues(stage)
    if omni and omni_validator_available():
        issues.extend(_omni_issues(path))
    return issues


def errors_only(issues: list[ValidationIssue]) -> list[ValidationIssue]:
    """The issues of severity ``error``."""
    return [i for i in issues if i.severity == "error"]
