"""An asset's dependencies are read once per process and again whenever one of its files changes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from usdworld.authoring import world
from usdworld.authoring.world import asset_dependencies, copy_asset
from usdworld.errors import AuthoringError

ROOT = '#usda 1.0\n(\n    defaultPrim = "Thing"\n{}\n)\n\ndef Xform "Thing"\n{{\n}}\n'


def _asset(folder: Path, sublayers: list[str]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name in sublayers:
        (folder / name).write_text("#usda 1.0\n")
    subs = f"    subLayers = [{', '.join(f'@./{n}@' for n in sublayers)}]\n" if sublayers else ""
    root = folder / "thing.usda"
    root.write_text(ROOT.format(subs))
    return root.resolve()


@pytest.fixture
def calls(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The paths ComputeAllDependencies was asked about."""
    seen: list[str] = []
    compute = world.UsdUtils.ComputeAllDependencies

    class Counting:
        @staticmethod
        def ComputeAllDependencies(path):  # noqa: N802 (pxr's name)
            seen.append(path.path)
            return compute(path)

    monkeypatch.setattr(world, "UsdUtils", Counting)
    monkeypatch.setattr(world, "_DEPENDENCIES", {})
    return seen


def test_an_unchanged_asset_is_read_once(tmp_path: Path, calls: list[str]) -> None:
    root = _asset(tmp_path / "lib", ["a.usda"])
    first = asset_dependencies(root)
    assert [p.name for p in first] == ["thing.usda", "a.usda"]
    assert asset_dependencies(root) == first
    assert len(calls) == 1
    copy_asset(root, tmp_path / "out")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["a.usda", "thing.usda"]
    assert len(calls) == 1


def test_a_changed_file_is_read_again(tmp_path: Path, calls: list[str]) -> None:
    root = _asset(tmp_path / "lib", ["a.usda"])
    asset_dependencies(root)
    _asset(tmp_path / "lib", ["a.usda", "b.usda"])  # the root layer now composes b too
    assert [p.name for p in asset_dependencies(root)] == ["thing.usda", "a.usda", "b.usda"]
    assert len(calls) == 2
    # a sublayer edited in place (same size, a later time) is read again too
    sub = tmp_path / "lib" / "a.usda"
    stat = sub.stat()
    os.utime(sub, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))
    asset_dependencies(root)
    assert len(calls) == 3


def test_a_missing_dependency_is_an_authoring_error_every_time(tmp_path: Path, calls: list[str]) -> None:
    root = _asset(tmp_path / "lib", ["a.usda"])
    asset_dependencies(root)
    (tmp_path / "lib" / "a.usda").unlink()
    for _ in range(2):
        with pytest.raises(AuthoringError, match="unresolved dependencies"):
            asset_dependencies(root)
