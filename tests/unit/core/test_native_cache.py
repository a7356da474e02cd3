"""The compiled-model cache cannot hurt (core.native): every way a cached library can be damaged gives the
right numbers with at most one notice line and never a crash; a killed compile leaves nothing for long; the
cache keeps to its size bound; `cvtdesign cache` shows it and `--clear` empties it.

The damaged caches are run by the console script in a subprocess: that is the point, since a truncated
library used to kill the process that loaded it with a bus error (exit 135, no output at all)."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import casadi as ca
import pytest
import yaml

from conftest import variant_data
from cvtdesign.cli import main
from cvtdesign.core import native

needs_compiler = pytest.mark.skipif(native.compiler() is None, reason="no C compiler on this machine")
NOTICE = "cvtdesign: the compiled-model cache {} held a damaged library (not the bytes compiled into it); " \
         "compiling it again"


def _script() -> list[str]:
    script = Path(sys.executable).parent / "cvtdesign"
    return [str(script)] if script.exists() else [sys.executable, "-m", "cvtdesign"]


def compare(folder: Path, cache: Path, policy: str = "always", variant: str = "small"):
    """`cvtdesign compare <variant>.yaml` in a subprocess with this cache and compile policy: (the run, its JSON)."""
    env = os.environ | {"CVTDESIGN_CACHE": str(cache), "CVTDESIGN_COMPILE": policy}
    out = folder / f"c{time.monotonic_ns()}.json"
    run = subprocess.run([*_script(), "compare", str(folder / f"{variant}.yaml"), "--out", str(folder / "plots"),
                          "--json", str(out)], env=env, capture_output=True, text=True, timeout=300)
    return run, json.loads(out.read_text()) if out.exists() else {}


def _variant(folder: Path, name: str, gamma_step: str, load_step: str):
    data = variant_data("existing_kim")
    data["envelope"] |= {"gamma": {"start": "-80 deg", "stop": "80 deg", "step": gamma_step},
                         "load": {"start": "-1 N*m", "stop": "1 N*m", "step": load_step}}
    (folder / f"{name}.yaml").write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(a folder with small.yaml and fine.yaml, a cache holding their two compiled models, the figures of
    each: small's interpreted, fine's compiled from the undamaged cache). fine.yaml is the issue's envelope
    (γ step 1°, load step 0.01 N·m): so many points that 'auto' waits for the library rather than evaluate
    them interpreted, and so loads the cached one; small.yaml never gets that far under 'auto'."""
    folder = tmp_path_factory.mktemp("cache")
    _variant(folder, "small", "20 deg", "0.5 N*m")
    _variant(folder, "fine", "1 deg", "0.01 N*m")
    run, figures = compare(folder, folder / "never", "never")
    assert run.returncode == 0 and figures, run.stderr
    run, compiled = compare(folder, folder / "cache")
    assert run.returncode == 0 and run.stderr == "" and compiled == figures
    assert len(list((folder / "cache").glob("*.so"))) == 2
    run, fine = compare(folder, folder / "cache", variant="fine")
    assert run.returncode == 0 and run.stderr == "" and len(list((folder / "cache").glob("*.so"))) == 2
    return folder, folder / "cache", {"small": figures, "fine": fine}


def truncate(libs):
    for lib in libs:
        os.truncate(lib, lib.stat().st_size // 5)


def random_bytes(libs):
    libs[0].write_bytes(os.urandom(libs[0].stat().st_size))


def swap(libs, suffixes=(".so",)):
    a, b = libs[:2]
    for s in suffixes:
        tmp = a.with_suffix(".swap")
        a.with_suffix(s).rename(tmp)
        b.with_suffix(s).rename(a.with_suffix(s))
        tmp.rename(b.with_suffix(s))


DAMAGE = {"truncated": truncate, "random bytes": random_bytes, "two libraries swapped": swap,
          "two libraries swapped with their sidecars": lambda libs: swap(libs, (".so", ".sha256"))}


@pytest.mark.slow
@needs_compiler
@pytest.mark.parametrize("how, policy", [(how, "always") for how in DAMAGE] +
                         [("truncated", "auto"), ("two libraries swapped", "auto")])
def test_a_damaged_cache_gives_the_right_numbers_with_one_notice(built, tmp_path, how, policy):
    """Truncated libraries killed every later run with a bus error (exit 135, nothing printed); random bytes
    printed 44 lines of CasADi's search path; two libraries swapped ended in a broadcasting traceback. Now
    each gives the interpreted model's figures exactly, with at most the one notice line, under both the
    'always' policy (compiled again at once) and 'auto' (interpreted while the detached process compiles)."""
    folder, good, figures = built
    cache, variant = tmp_path / "cache", "small" if policy == "always" else "fine"
    subprocess.run(["cp", "-a", str(good), str(cache)], check=True)
    DAMAGE[how](sorted(cache.glob("*.so")))
    run, got = compare(folder, cache, policy, variant)
    assert run.returncode == 0, run.stderr
    assert run.stderr == NOTICE.format(cache) + "\n"
    assert got == figures[variant]
    assert all(native.verified(lib) for lib in cache.glob("*.so"))


@needs_compiler
def test_a_library_that_passes_its_checksum_but_cannot_load_is_one_line(tmp_path, monkeypatch):
    """A library whose sidecar matches but which is not a library of this machine, or holds another model:
    `load` refuses it in one line, without CasADi's account of its search path."""
    monkeypatch.setenv("CVTDESIGN_CACHE", str(tmp_path))
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    square = ca.Function("square", [x], [x * x])
    lib = native.build(native.source(square), native.compiler())
    assert float(native.load(lib, "square", like=square)(3.0)) == 9.0
    with pytest.raises(RuntimeError, match=r"holds another model") as e:
        native.load(lib, "square", like=ca.Function("square", [x, y], [x * y]))
    assert "\n" not in str(e.value)
    fake = tmp_path / ("0" * 32 + ".so")
    fake.write_bytes(b"not a shared library " * 100)
    fake.with_suffix(".sha256").write_text(native._fingerprint(fake.read_bytes(), fake.name))
    with pytest.raises(RuntimeError) as e:
        native.load(fake, "square")
    assert "invalid ELF header" in str(e.value) and "Searched" not in str(e.value) and "\n" not in str(e.value)


@needs_compiler
def test_a_compile_killed_midway_leaves_nothing_behind_for_long(tmp_path, monkeypatch):
    """A compile killed while the compiler runs left its `.build-*` folder (and the detached process's
    source) in the cache for good; the next build removes both (the folder because nobody holds its
    library's lock, the source once it is older than STALE_SECONDS) and the cache works."""
    monkeypatch.setenv("CVTDESIGN_CACHE", str(tmp_path / "cache"))
    slow = tmp_path / "slowcc"
    slow.write_text("#!/bin/sh\nsleep 60\n")
    slow.chmod(0o755)
    x = ca.SX.sym("x")
    code = native.source(ca.Function("cube", [x], [x ** 3]))
    cache = tmp_path / "cache"
    cache.mkdir()
    src = cache / ".source-killed.c"           # as build_detached hands it to its process
    src.write_text(code)
    proc = subprocess.Popen([sys.executable, "-m", "cvtdesign.core.native", str(src), str(slow)],
                            start_new_session=True)
    for _ in range(600):
        if list(cache.glob(".build-*/model.c")):
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)         # the compile's process and its compiler, mid-compile
    proc.wait()
    assert list(cache.glob(".build-*")) and src.exists()          # what a kill leaves
    monkeypatch.setattr(native, "STALE_SECONDS", 0.0)
    lib = native.build(code, native.compiler())
    assert native.verified(lib) and float(native.load(lib, "cube")(2.0)) == 8.0
    assert not list(cache.glob(".build-*")) and not list(cache.glob(".source-*"))


def fake_library(cache: Path, k: int, size: int, used: float) -> Path:
    lib = cache / f"{k:032x}.so"
    lib.write_bytes(bytes(size))
    lib.with_suffix(".sha256").write_text(native._fingerprint(lib.read_bytes(), lib.name))
    os.utime(lib.with_suffix(".sha256"), (used, used))
    return lib


def test_the_cache_keeps_to_its_size_bound(tmp_path, monkeypatch):
    """The cache was never pruned. Past its bound, the libraries used longest ago go (with their sidecars and
    locks), except the one just built and any whose lock a compile holds; other files are never touched."""
    monkeypatch.setenv("CVTDESIGN_CACHE", str(tmp_path))
    libs = [fake_library(tmp_path, k, 100_000, used=1e9 + k) for k in range(6)]
    (tmp_path / "notes.txt").write_text("the user's own file\n")
    from filelock import FileLock
    with FileLock(str(libs[1].with_suffix(".lock"))):       # in use by a compile: kept
        native.prune(keep=libs[0], limit=350_000)
    kept = sorted(p.name for p in tmp_path.glob("*.so"))
    assert kept == [libs[k].name for k in (0, 1, 5)]
    assert not libs[2].with_suffix(".sha256").exists() and (tmp_path / "notes.txt").exists()


@needs_compiler
def test_a_build_prunes_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CVTDESIGN_CACHE", str(tmp_path))
    old = [fake_library(tmp_path, k, 200_000, used=1e9 + k) for k in range(3)]
    monkeypatch.setattr(native, "MAX_CACHE_BYTES", 250_000)
    x = ca.SX.sym("x")
    lib = native.build(native.source(ca.Function("twice", [x], [2 * x])), native.compiler())
    assert lib.exists() and [p.exists() for p in old] == [False, False, True]     # the oldest two went


def test_cache_command_shows_and_clears(tmp_path, monkeypatch, capsys):
    """`cvtdesign cache` says where the cache is and how big; `--clear` removes the cache's own files only."""
    monkeypatch.setenv("CVTDESIGN_CACHE", str(tmp_path))
    for k in range(2):
        fake_library(tmp_path, k, 2**20, used=1e9)
    (tmp_path / ".build-x-1").mkdir()
    (tmp_path / "notes.txt").write_text("the user's own file\n")
    assert main(["cache"]) == 0
    out = capsys.readouterr().out
    assert f"compiled-model cache: {tmp_path}" in out and "2 compiled models, 2.0 MB" in out
    assert main(["cache", "--clear"]) == 0
    assert f"removed 2 compiled models (2.0 MB) from {tmp_path}" in capsys.readouterr().out
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]
    assert main(["cache"]) == 0 and "0 compiled models" in capsys.readouterr().out
