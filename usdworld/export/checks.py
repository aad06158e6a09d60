"""Checks run on every export: USD validators, the Khronos glTF validator, consumer constraints.

- USD outputs: UsdValidation and, where installed, omni-asset-validator must report no
  error. The world's own layers and prims are validated every time; an asset whose card (in
  the world's ``assets/``) matches the exported files and records a clean validation by the
  same validators is not validated again (:mod:`usdworld.authoring.validation_scope`). A
  ``usda-flat`` export is text by request, so omni's ``UsdAsciiPerformanceChecker`` (large
  arrays belong in crate files) is not counted against it.
- Every ``.usdc`` written: crate version 0.8.0 or older (what USD 20.08 in Unity reads).
- No payload arcs anywhere (Unity's USD package does not load payloads by default).
- GLB: the Khronos glTF validator (npm ``gltf-validator``, run with node through
  ``web/validate_gltf.mjs``) must report 0 errors. It is found in ``$USDWORLD_WEB_DIR`` or
  the source checkout's ``web/`` after ``tools/setup_web.sh``; where it is not installed
  the check is reported as not run.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from usdworld.authoring.validate import ValidationIssue, errors_only, validator_ids
from usdworld.errors import InputError, OutputError
from usdworld.export.usd_formats import check_crate_version, objects_with_payloads, open_world

#: omni rules not counted against a usda-flat export (text with large arrays is its purpose).
TEXT_EXEMPT_RULES = ("UsdAsciiPerformanceChecker",)
#: Seconds the glTF validator may take.
GLTF_VALIDATOR_TIMEOUT_S = 120


@dataclass(frozen=True)
class CheckReport:
    """The outcome of checking one export.

    Attributes:
        checker: what ran (``usd``, ``gltf-validator``).
        errors: error messages; empty when the export passed.
        warnings: warning messages.
        skipped: why the checker did not run ('' when it ran).
    """

    checker: str
    errors: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    skipped: str = ""
    details: dict = field(default_factory=dict, hash=False, compare=False)

    @property
    def ok(self) -> bool:
        """True when the checker ran (or was skipped) and found no error."""
        return not self.errors


def _format(issue: ValidationIssue) -> str:
    return f"[{issue.validator}:{issue.rule}] {issue.at} {issue.message}".replace("  ", " ")


def check_usd_export(path: Path, fmt: str, *, omni: bool = True, cards_dir: Path | None = None) -> CheckReport:
    """Validate a USD export and check the constraints of the consumers.

    Args:
        path: the exported ``.usdz``/``.usdc``/``.usda``.
        fmt: the export format (``usdz``, ``usdc``, ``usda-flat``).
        omni: also run omni-asset-validator where installed.
        cards_dir: the folder of the asset cards that may vouch for exported assets (the
            world's ``assets/``); None validates everything.

    Returns:
        The report; ``details`` holds what was validated (``trusted_assets``,
        ``layers_checked``, ``layers_skipped``, ``prims_checked``, ``subtrees_skipped``).
    """
    from usdworld.authoring.validation_scope import validate_scoped
    from usdworld.io.images import native_stderr_captured

    # USD also prints what the validators report straight to stderr; the issues carry it
    with native_stderr_captured(str(path)):
        stage = open_world(path)
        scoped = validate_scoped(path, stage, cards_dir, validator_ids(omni=omni))
    issues = scoped.issues
    exempt = TEXT_EXEMPT_RULES if fmt == "usda-flat" else ()
    errors = [_format(i) for i in errors_only(issues) if i.rule not in exempt]
    warnings = [_format(i) for i in issues if i.severity != "error" or i.rule in exempt]
    crates = [path] if path.suffix == ".usdc" else []
    if path.suffix == ".usdz":
        with zipfile.ZipFile(path) as zf:
            members = [n for n in zf.namelist() if n.endswith(".usdc")]
            with_crates = {n: zf.read(n)[:16] for n in members}
        for name, head in with_crates.items():
            if head[:8] == b"PXR-USDC" and tuple(head[8:11]) > (0, 8, 0):
                errors.append(f"{name}: crate version {'.'.join(map(str, head[8:11]))} is newer than 0.8.0")
    for crate in crates:
        try:
            check_crate_version(crate)
        except OutputError as exc:  # a check failure, reported with the others
            errors.append(str(exc))
    payloads = objects_with_payloads(stage)
    if payloads:
        errors.append(f"payload arcs on {', '.join(payloads)}: Unity's USD package does not load payloads by default")
    details = {
        "trusted_assets": list(scoped.trusted_assets),
        "layers_checked": scoped.layers_checked,
        "layers_skipped": scoped.layers_skipped,
        "prims_checked": scoped.prims_checked,
        "subtrees_skipped": scoped.subtrees_skipped,
    }
    return CheckReport("usd", tuple(errors), tuple(warnings), details=details)


def web_dir() -> Path | None:
    """The ``web/`` folder with the npm tools (``$USDWORLD_WEB_DIR`` or the source checkout's)."""
    env = os.environ.get("USDWORLD_WEB_DIR")
    candidates = [Path(env)] if env else []
    candidates.append(Path(__file__).resolve().parents[2] / "web")
    for c in candidates:
        if (c / "validate_gltf.mjs").is_file():
            return c
    return None


def gltf_validator_command() -> tuple[list[str] | None, str]:
    """The command that runs the Khronos validator (without the file), or None and why not."""
    node = shutil.which("node")
    where = web_dir()
    if node is None:
        return None, "node is not installed (run tools/setup_web.sh)"
    if where is None:
        return None, "the web/ tools are not in this installation (set USDWORLD_WEB_DIR to a checkout's web/)"
    if not (where / "node_modules" / "gltf-validator").is_dir():
        return None, f"gltf-validator is not installed in {where} (run tools/setup_web.sh)"
    return [node, str(where / "validate_gltf.mjs")], ""


def run_gltf_validator(path: Path) -> dict:
    """The Khronos validator's JSON report for one file.

    Raises:
        InputError: the validator is not installed or did not produce a report.
    """
    command, why = gltf_validator_command()
    if command is None:
        raise InputError(f"cannot run the Khronos glTF validator: {why}")
    proc = subprocess.run(
        [*command, str(path)], capture_output=True, text=True, timeout=GLTF_VALIDATOR_TIMEOUT_S, check=False
    )
    try:
        return json.loads(proc.stdout)
    except json.JSONDecodeError as exc:
        raise InputError(f"glTF validator gave no report for {path}: {proc.stderr.strip()[-500:]}") from exc


def check_glb_export(path: Path) -> CheckReport:
    """Run the Khronos glTF validator on a ``.glb``; skipped (with the reason) where not installed."""
    command, why = gltf_validator_command()
    if command is None:
        return CheckReport("gltf-validator", skipped=why)
    report = run_gltf_validator(path)
    messages = report.get("issues", {}).get("messages", [])
    errors = tuple(f"{m['code']} at {m.get('pointer', '')}: {m['message']}" for m in messages if m.get("severity") == 0)
    warnings = tuple(f"{m['code']} at {m.get('pointer', '')}: {m['message']}" for m in messages if m.get("severity") == 1)
    return CheckReport("gltf-validator", errors, warnings, details=report)
