"""The ``-o`` world folder: symbolic links refused, names that fit, umask, renames only."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from usdworld.errors import OutputError
from usdworld.output_dir import current_umask, prepare_output, swap_in


def test_symlink_to_world_refused(tmp_path: Path) -> None:
    real = tmp_path / "real"
    real.mkdir()
    (real / "world.usda").write_text("#usda 1.0\n")
    link = tmp_path / "link"
    link.symlink_to(real)
    with pytest.raises(OutputError, match=rf"^{link}: is a symbolic link \(to {real}\); .* -o {real}$"):
        prepare_output(link)
    assert link.is_symlink() and (real / "world.usda").read_text() == "#usda 1.0\n"


def test_dangling_symlink_refused(tmp_path: Path) -> None:
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "nowhere")
    with pytest.raises(OutputError, match=r"is a dangling symbolic link \(to .*nowhere\); remove it"):
        prepare_output(link)
    assert link.is_symlink()


def test_name_too_long(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match=r"the output name is 250 bytes, the file system allows 241"):
        prepare_output(tmp_path / ("a" * 250))
    assert prepare_output(tmp_path / ("a" * 241)) is None


def test_existing_world_keeps_edits(tmp_path: Path) -> None:
    out = tmp_path / "w"
    (out / "layers").mkdir(parents=True)
    (out / "world.usda").write_text("")
    assert prepare_output(out) is None
    (out / "layers" / "edits.usda").write_text("")
    assert prepare_output(out) == out / "layers" / "edits.usda"
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "x").write_text("")
    with pytest.raises(OutputError, match=r"is not empty and holds no world\.usda"):
        prepare_output(tmp_path / "other")


@pytest.mark.parametrize("umask", [0o022, 0o027, 0o002])
def test_swap_in_follows_umask(tmp_path: Path, umask: int) -> None:
    old = os.umask(umask)
    try:
        assert current_umask() == umask
        tmp = tmp_path / ".w.tmp-x"
        tmp.mkdir(mode=0o700)
        (tmp / "world.usda").write_text("new")
        out = tmp_path / "w"
        out.mkdir()
        (out / "world.usda").write_text("old")
        swap_in(tmp, out)
    finally:
        os.umask(old)
    assert (out / "world.usda").read_text() == "new"
    assert out.stat().st_mode & 0o777 == 0o777 & ~umask
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w"]
