"""A compiled-model cache that cannot be changed (issue 38): `cache --clear` says what it removed and what it
could not, with exit status 2 (it printed "removed 2 compiled models" and exit 0, and both were still there);
a run that cannot write the cache says so once (it printed one notice per model, each naming its own lock
file).

The folder is made unchangeable with the immutable attribute (chattr +i), which holds even for root, who
may write any folder whatever its mode; where chattr is not available, `cache --clear` is checked with the
removal failing as it would (PermissionError), and the notice test is skipped."""
from __future__ import annotations

import pathlib
import shutil
import subprocess

import pytest

from cvtdesign.cli import main
from cvtdesign.core import native


def _fake_library(folder: pathlib.Path, k: int, size: int) -> pathlib.Path:
    lib = folder / f"{k:032x}.so"
    lib.write_bytes(b"\0" * size)
    lib.with_suffix(".sha256").write_text(native._fingerprint(lib.read_bytes(), lib.name))
    return lib


def _chattr(folder: pathlib.Path, flag: str) -> bool:
    if shutil.which("chattr") is None:
        return False
    return subprocess.run(["chattr", flag, str(folder)], capture_output=True).returncode == 0


@pytest.fixture
def unchangeable(tmp_path, monkeypatch):
    """A cache folder holding two compiled models that cannot be removed: (folder, whether it is immutable)."""
    folder = tmp_path / "cache"
    folder.mkdir()
    libs = [_fake_library(folder, k, 2**20) for k in range(2)]
    monkeypatch.setenv("CVTDESIGN_CACHE", str(folder))
    immutable = _chattr(folder, "+i")
    if not immutable:
        real = pathlib.Path.unlink

        def unlink(self, missing_ok=False):
            if self.parent == folder:
                raise PermissionError(1, "Operation not permitted", str(self))
            return real(self, missing_ok)
        monkeypatch.setattr(pathlib.Path, "unlink", unlink)
    yield folder, immutable, libs
    if immutable:
        _chattr(folder, "-i")


def test_cache_clear_on_a_folder_it_cannot_change_says_so(unchangeable, capsys):
    folder, _, libs = unchangeable
    assert main(["cache", "--clear"]) == 2
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert out == "" and len(lines) == 1, (out, err)
    assert lines[0].startswith("cvtdesign: error: cache --clear: removed 0 compiled models (0.0 MB) from "
                               f"{folder}; could not remove 4 files (2 compiled models)"), lines[0]
    assert "Operation not permitted" in lines[0]
    assert all(p.exists() for p in libs)


def test_cache_clear_reports_what_it_removed_beside_what_it_could_not(tmp_path, monkeypatch, capsys):
    """One library removable, one not (its removal fails): the line says 1 removed, 2 files left."""
    folder = tmp_path / "cache"
    folder.mkdir()
    keep, gone = (_fake_library(folder, k, 2**20) for k in range(2))
    monkeypatch.setenv("CVTDESIGN_CACHE", str(folder))
    real = pathlib.Path.unlink

    def unlink(self, missing_ok=False):
        if self.stem == keep.stem:
            raise PermissionError(13, "Permission denied", str(self))
        return real(self, missing_ok)
    monkeypatch.setattr(pathlib.Path, "unlink", unlink)
    assert main(["cache", "--clear"]) == 2
    err = capsys.readouterr().err
    assert "removed 1 compiled models (1.0 MB)" in err and "could not remove 2 files (1 compiled models)" in err, err
    assert keep.exists() and not gone.exists()


@pytest.mark.slow
def test_a_cache_that_cannot_be_written_gives_one_notice(unchangeable, tmp_path, monkeypatch, capfd):
    """compare compiles three models (box, Kim's CVT, the ideal CVT) with CVTDESIGN_COMPILE=always: one notice
    naming the folder, and the same figures as interpreted."""
    folder, immutable, _ = unchangeable
    if not immutable:
        pytest.skip("chattr +i is not available here: no folder this user cannot write")
    from conftest import ROOT
    monkeypatch.setenv("CVTDESIGN_COMPILE", "always")
    assert main(["compare", str(ROOT / "variants" / "box_kim.yaml"), "--out", str(tmp_path / "p")]) == 0
    err = [ln for ln in capfd.readouterr().err.splitlines() if ln.strip()]
    assert err == [f"cvtdesign: the compiled-model cache {folder} cannot be written (Operation not permitted): "
                   "the models run interpreted, several times slower; set CVTDESIGN_CACHE to a folder this user "
                   "may write"], err
