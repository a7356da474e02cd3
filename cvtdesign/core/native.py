"""Compiled model functions: a CasADi Function generated as C, compiled once by the machine's C compiler,
cached on disk and loaded on later runs.

The cache is internal, not the tool's output, so it is written here and not through io/output.py. It is
the folder CVTDESIGN_CACHE, else $XDG_CACHE_HOME/cvtdesign, else ~/.cache/cvtdesign; `cvtdesign cache`
shows it and `cvtdesign cache --clear` empties it. A library is named by the SHA-256 of its C source and the
compile command, so a changed model, CasADi version or flag never loads a stale one. Processes that compile
the same library at once (Dask workers) take a file lock on its name; the first compiles in a folder
`.build-<name>-*` and renames the library into place (os.replace), the others then find it.

A cached library cannot hurt: loading a damaged one (truncated: a bus error that killed the process; random
bytes; another model's library in its place: a traceback) is prevented, not caught. The compiling process
writes the sidecar <library>.sha256 with the library's SHA-256, size and name, and renames it into place
just before the library, so no library is there without it. A library is loaded only when its bytes match
its sidecar (`verified`), and used only when its inputs and outputs are the model's. A library that fails
is compiled again (or, while that runs, the model runs interpreted), with one notice line. Compile folders
left by a killed compile are removed once nobody holds their library's lock, and the cache is kept under
MAX_CACHE_BYTES: past it, the libraries used longest ago are removed.

The compiler is $CC, else the first of cc, gcc, clang on the PATH. Without one, the model stays interpreted
(CasADi's virtual machine: the same numbers, slower), and one line on stderr says so once per process.

When to compile (CVTDESIGN_COMPILE):
 * 'auto' (default): `Tiered` evaluates a function interpreted until its interpreted evaluations have
   taken HOT_SECONDS, then compiles it in a separate process and switches to the library once it is in
   the cache. A model used for longer than its compile takes pays for the compile; one used briefly never
   waits for the compiler. A call estimated to take longer than WAIT_SECONDS interpreted waits for the
   library instead, and so does the first call of a run that announced (`Tiered.expect`) evaluations
   estimated to take that long (a diagnosis: about 900 evaluations of its rows). `Tiered.start` starts the
   detached compile at once (a diagnosis's derivative function, beside its rows' function). The compiling
   process is detached: a command that ends first still leaves the library for the next run.
 * 'always': compile at first use and wait for it. 'never': stay interpreted.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable

import casadi as ca
from filelock import FileLock, Timeout

FLAGS = ["-O1", "-fPIC", "-shared"]   # -O3 compiles 2–3× longer for no faster model (docs/benchmarks.md)
HOT_SECONDS = 1.0       # interpreted evaluation time of one function after which 'auto' compiles it
WAIT_SECONDS = 3.0      # a call estimated to take longer than this interpreted waits for the compiler
POLICIES = ("auto", "always", "never")
MAX_CACHE_BYTES = 512 * 2**20   # the cache's size bound: past it, the libraries used longest ago are removed
STALE_SECONDS = 3600.0  # a compiler source of a detached compile not started this long ago is left over
CACHE_FORMAT = "2"      # part of every library's name: libraries cached before their sidecars are never looked up
CACHE_FILE = re.compile(r"[0-9a-f]{32}\.(so|sha256|lock|err)|\.build-.*|\.source-.*\.c")   # the cache's own files
DAMAGED = "the compiled-model cache {} held a damaged library (not the bytes compiled into it); compiling it again"

_noticed: set = set()
_notice_lock = threading.Lock()


def policy() -> str:
    """CVTDESIGN_COMPILE: 'auto' (default), 'always' or 'never' (module docstring)."""
    value = os.environ.get("CVTDESIGN_COMPILE", "").strip().lower() or "auto"
    if value not in POLICIES:
        notice(f"CVTDESIGN_COMPILE={value!r} is not one of {', '.join(POLICIES)}: using 'auto'")
        return "auto"
    return value


def cache_dir() -> Path:
    """The folder of compiled libraries: CVTDESIGN_CACHE, else $XDG_CACHE_HOME/cvtdesign, else
    ~/.cache/cvtdesign."""
    if os.environ.get("CVTDESIGN_CACHE"):
        return Path(os.environ["CVTDESIGN_CACHE"]).expanduser()
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache").expanduser() / "cvtdesign"


def compiler() -> list[str] | None:
    """The C compiler command: $CC (split like a shell command), else cc, gcc or clang on the PATH; None
    if there is none."""
    if os.environ.get("CC"):
        command = shlex.split(os.environ["CC"])
        return command if command and shutil.which(command[0]) else None
    return next(([name] for name in ("cc", "gcc", "clang") if shutil.which(name)), None)


def notice(message: str) -> None:
    """`message` as one line on stderr, the first time it comes up in this process."""
    with _notice_lock:
        if message in _noticed:
            return
        _noticed.add(message)
    print(f"cvtdesign: {message}", file=sys.stderr)


def source(fn: ca.Function, derivatives: bool = False) -> str:
    """C source of fn and, with `derivatives`, of its forward and reverse derivatives (fwd1_<name> and
    adj1_<name>: what CasADi's `external` looks for when a graph that calls the library is differentiated)."""
    gen = ca.CodeGenerator("cvtdesign_model", {"with_header": False})
    gen.add(fn)
    if derivatives:
        gen.add(fn.forward(1))
        gen.add(fn.reverse(1))
    return gen.dump()


def library_path(code: str, command: list[str]) -> Path:
    """Where the library of this C source, compiled by this command, lives in the cache."""
    digest = hashlib.sha256("\0".join([CACHE_FORMAT, code, *command, *FLAGS]).encode()).hexdigest()[:32]
    return cache_dir() / f"{digest}.so"


def _fingerprint(data: bytes, name: str) -> str:
    """A library's sidecar text: the SHA-256, size and name of its bytes."""
    return f"{hashlib.sha256(data).hexdigest()} {len(data)} {name}\n"


def verified(lib: Path) -> bool:
    """Whether `lib` holds exactly the bytes that were compiled into it: those its sidecar <lib>.sha256 names,
    by SHA-256, size and file name (so a library moved in from another name fails)."""
    try:
        return lib.with_suffix(".sha256").read_text() == _fingerprint(lib.read_bytes(), lib.name)
    except (OSError, UnicodeDecodeError):
        return False


def _remove(*paths: Path, failed: list | None = None) -> int:
    """Remove files and folders of the cache (those already gone are skipped); returns the bytes freed. Those
    that cannot be removed are left, each appended to `failed` (when given) as (path, reason)."""
    freed = 0
    for p in paths:
        try:
            if p.is_dir() and not p.is_symlink():
                size = sum(f.stat().st_size for f in p.rglob("*") if f.is_file())
                shutil.rmtree(p)
            else:
                size = p.stat().st_size
                p.unlink()
            freed += size
        except FileNotFoundError:
            pass
        except OSError as e:
            if failed is not None:
                failed.append((p, e.strerror or type(e).__name__))
    return freed


def build(code: str, command: list[str]) -> Path:
    """The library of `code`: from the cache if `verified`, else compiled by `command` now (lock, a
    `.build-<name>-` folder, rename, sidecar: module docstring); a damaged one is replaced, with the DAMAGED
    notice. Raises RuntimeError with the compiler's first error line if it fails."""
    lib = library_path(code, command)
    lib.parent.mkdir(parents=True, exist_ok=True)
    with FileLock(str(lib.with_suffix(".lock"))):
        if verified(lib):
            os.utime(lib.with_suffix(".sha256"))        # its last use, for `prune`
            return lib
        if lib.exists():
            notice(DAMAGED.format(lib.parent))
        _remove(lib, lib.with_suffix(".sha256"))
        _remove(*lib.parent.glob(f".build-{lib.stem}-*"))  # a killed compile's: nobody else builds it now
        with tempfile.TemporaryDirectory(dir=lib.parent, prefix=f".build-{lib.stem}-") as tmp:
            src, out, side = Path(tmp) / "model.c", Path(tmp) / "model.so", Path(tmp) / "model.sha256"
            src.write_text(code)
            done = subprocess.run([*command, *FLAGS, str(src), "-o", str(out), "-lm"], capture_output=True, text=True)
            if done.returncode != 0:
                lines = done.stderr.splitlines()
                raise RuntimeError(f"{' '.join(command)} failed: "
                                   f"{next((ln for ln in lines if 'error' in ln), lines[0] if lines else '')}")
            side.write_text(_fingerprint(out.read_bytes(), lib.name))
            os.replace(side, lib.with_suffix(".sha256"))    # first: a library is never there without it
            os.replace(out, lib)
    prune(keep=lib)
    return lib


def prune(keep: Path | None = None, limit: int | None = None) -> None:
    """Tidy the cache: remove the compile folders of killed compiles (those whose library's lock nobody
    holds), compiler sources of detached compiles older than STALE_SECONDS, and, while the cache is larger
    than `limit` (default MAX_CACHE_BYTES), the libraries used longest ago (by their sidecar's time, which
    each load renews), except `keep` and those in use by a compile (their lock held)."""
    folder, limit = cache_dir(), MAX_CACHE_BYTES if limit is None else limit
    for d in folder.glob(".build-*"):
        stem = d.name[len(".build-"):].split("-")[0]
        if not re.fullmatch(r"[0-9a-f]{32}", stem):       # a compile folder of an older cvtdesign
            if _age(d) > STALE_SECONDS:
                _remove(d)
            continue
        with _unlocked(folder / f"{stem}.lock") as free:
            if free:
                _remove(d)
    for s in folder.glob(".source-*.c"):
        if _age(s) > STALE_SECONDS:
            _remove(s)
    files = [f for f in folder.iterdir() if CACHE_FILE.fullmatch(f.name) and f.is_file()]
    size = sum(f.stat().st_size for f in files)
    for lib in sorted((f for f in files if f.suffix == ".so" and f != keep), key=_last_use):
        if size <= limit:
            break
        with _unlocked(lib.with_suffix(".lock")) as free:
            if free:
                size -= _remove(lib, lib.with_suffix(".sha256"), lib.with_suffix(".err"))


@contextlib.contextmanager
def _unlocked(path: Path):
    """Hold the lock `path` for the block if nobody else holds it; yields whether it is held."""
    lock = FileLock(str(path), timeout=0)
    try:
        lock.acquire()
    except (Timeout, OSError):
        yield False
        return
    try:
        yield True
    finally:
        lock.release()


def _age(path: Path) -> float:
    try:
        return time.time() - path.stat().st_mtime
    except OSError:
        return 0.0


def _last_use(lib: Path) -> float:
    for p in (lib.with_suffix(".sha256"), lib):
        try:
            return p.stat().st_mtime
        except OSError:
            continue
    return 0.0


def cache_summary() -> dict:
    """The cache as `cvtdesign cache` shows it: its folder, how many libraries, its size in bytes, the bound."""
    folder = cache_dir()
    files = [f for f in folder.iterdir() if CACHE_FILE.fullmatch(f.name)] if folder.is_dir() else []
    size = sum(f.stat().st_size for f in files if f.is_file())
    return {"folder": folder, "libraries": sum(f.suffix == ".so" for f in files), "bytes": size,
            "limit": MAX_CACHE_BYTES}


def clear_cache() -> tuple[int, int, list]:
    """Remove every file of the cache (`cvtdesign cache --clear`), and only those (CACHE_FILE: the folder
    may be one the user shares with other files); returns (libraries, bytes) removed and the (path, reason)
    of each file that could not be."""
    folder = cache_dir()
    if not folder.is_dir():
        return 0, 0, []
    files, failed = [f for f in folder.iterdir() if CACHE_FILE.fullmatch(f.name)], []
    freed = _remove(*files, failed=failed)
    left = {p for p, _ in failed}
    return sum(f.suffix == ".so" and f not in left for f in files), freed, failed


def build_detached(code: str, command: list[str]) -> Path:
    """Start compiling `code` in a detached process (`python -m cvtdesign.core.native SOURCE`) and return
    where its library will appear; a failed compile leaves <library>.err with the reason instead."""
    lib = library_path(code, command)
    lib.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=lib.parent, prefix=".source-", suffix=".c")
    with os.fdopen(fd, "w") as f:
        f.write(code)
    subprocess.Popen([sys.executable, "-m", "cvtdesign.core.native", tmp, *command], start_new_session=True,
                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return lib


def load(lib: Path, name: str, like: ca.Function | None = None) -> ca.Function:
    """The function `name` of a `verified` library (with its derivatives, if the library has them), whose
    inputs and outputs are the sizes of `like`'s (when given). Raises RuntimeError in one line otherwise:
    a damaged library is never handed to the loader, and CasADi's account of its search path never shown."""
    if not verified(lib):
        raise RuntimeError(f"{lib.name} in {lib.parent} is not the library that was compiled")
    try:
        fn = ca.external(name, str(lib))
    except RuntimeError as e:
        why = re.search(rf"Error code: {re.escape(str(lib))}: (.*)", str(e))
        raise RuntimeError(f"cannot load {lib}: {why[1] if why else 'not a library of this machine'}") from None
    if like is not None and _signature(fn) != _signature(like):
        raise RuntimeError(f"{lib} holds another model (inputs and outputs of other sizes)")
    return fn


def _signature(fn: ca.Function) -> tuple:
    """The sizes of a function's inputs and outputs."""
    return (tuple(fn.size_in(i) for i in range(fn.n_in())), tuple(fn.size_out(i) for i in range(fn.n_out())))


def _failed(err: Exception, what: str = "compiling the model failed, it runs interpreted") -> None:
    """The notice of a compile that failed, one per fault: a cache folder that cannot be written (an OSError:
    read-only, full, not a folder) is named with its reason, the same words for every model, so it is said once
    a process and not once per model (whose lock file each error named); a compiler's error with its line."""
    if isinstance(err, OSError):
        notice(f"the compiled-model cache {cache_dir()} cannot be written ({err.strerror or type(err).__name__}): "
               "the models run interpreted, several times slower; set CVTDESIGN_CACHE to a folder this user may "
               "write")
    else:
        notice(f"{what}: {err}")


def shared_library(code: str) -> Path | None:
    """The cached library of a C source of the package's own (core.contact.surface), compiled now if it is
    not there, or None, with a notice, where there is no working compiler."""
    command = compiler()
    if command is None:
        notice("no C compiler found (set CC): the model runs interpreted, several times slower")
        return None
    try:
        return build(code, command)
    except (RuntimeError, OSError) as err:
        _failed(err, "compiling failed, the model runs interpreted")
        return None


def compiled(fn: ca.Function, derivatives: bool = False) -> ca.Function | None:
    """fn as a compiled library (from the cache, else compiled now), or None, with a notice, where there is
    no working compiler."""
    return from_source(source(fn, derivatives), fn.name(), like=fn)


def from_source(code: str, name: str, like: ca.Function | None = None) -> ca.Function | None:
    """The function `name` of the library of C source `code` (`source`'s, possibly made in another process):
    from the cache, else compiled now; None, with a notice, where there is no working compiler."""
    command = compiler()
    if command is None:
        notice("no C compiler found (set CC): the model runs interpreted, several times slower")
        return None
    try:
        return load(build(code, command), name, like=like)
    except (RuntimeError, OSError) as err:
        _failed(err)
        return None


class Tiered:
    """A function evaluated interpreted until its compiled library is there (module docstring: when).

    `interpreted` is the function to start with; `written_out()` builds the function to compile: the same
    inputs, outputs and numbers, in nodes that can be code-generated."""

    def __init__(self, interpreted: ca.Function, written_out: Callable[[], ca.Function],
                 native: ca.Function | None = None):
        self.interpreted = interpreted
        self.written_out = written_out
        self._code: str | None = None
        self.native = native        # the compiled function, once there (given: already compiled)
        self.seconds = 0.0             # interpreted evaluation time so far
        self.per_point = 1e-4          # interpreted seconds a point, as last measured
        self.pending: tuple | None = None    # (code, command, library) of the compile under way
        self.given_up = False
        self.expected = 0              # points announced to come (`expect`)
        self.lock = threading.Lock()

    def expect(self, points: int) -> None:
        """Announce that about `points` more points will be evaluated: whether to wait for the compiler is then
        judged on them all, not on the next call alone."""
        with self.lock:
            self.expected += points

    def start(self) -> None:
        """Compile now, however little it was used: a detached compile ('always': waited for; 'never': none),
        whose library later calls use once it is there; the cached library, if it is there."""
        with self.lock:
            if self.native is None and not self.given_up:
                self._advance(HOT_SECONDS - self.seconds)

    def function(self, points: int) -> ca.Function:
        """The function to evaluate `points` points with: compiled if it is there (or worth waiting for),
        else interpreted."""
        with self.lock:
            if self.native is None and not self.given_up:
                self._advance(max(points, self.expected) * self.per_point)
            return self.native or self.interpreted

    def code(self) -> str:
        """The C source of the function to compile (made once)."""
        if self._code is None:
            self._code = source(self.written_out())
        return self._code

    def record(self, fn: ca.Function, points: int, seconds: float) -> None:
        """Count an evaluation's wall time towards compiling (interpreted ones only)."""
        if fn is self.interpreted and points:
            with self.lock:
                self.seconds += seconds
                self.per_point = seconds / points

    def _advance(self, estimate: float) -> None:
        mode = policy()
        if mode == "never":
            return
        wait = mode == "always" or estimate >= WAIT_SECONDS
        if self.pending is None:
            if not wait and self.seconds + estimate < HOT_SECONDS:
                return
            command = compiler()
            if command is None:
                notice("no C compiler found (set CC): the model runs interpreted, several times slower")
                self.given_up = True
                return
            code = self.code()
            lib = library_path(code, command)
            ready = verified(lib)
            if not ready and lib.exists():
                notice(DAMAGED.format(lib.parent))    # build replaces it, here or in the detached process
            if not (wait or ready):
                try:
                    build_detached(code, command)
                except OSError as err:       # the cache cannot be written: its compiler source cannot go there
                    _failed(err)
                    self.given_up = True
                    return
            self.pending = (code, command, lib)
        code, command, lib = self.pending
        if lib.with_suffix(".err").exists():
            notice(f"compiling the model failed, it runs interpreted: {lib.with_suffix('.err').read_text().strip()}")
            self.given_up = True
        elif wait or verified(lib):
            try:
                self.native = load(build(code, command), self.interpreted.name(), like=self.interpreted)
            except (RuntimeError, OSError) as err:
                _failed(err)
                self.given_up = True


def _build_main(argv: list[str]) -> None:
    """`python -m cvtdesign.core.native SOURCE COMPILER...`: build_detached's process. Compiles SOURCE into
    the cache (or writes <library>.err) and removes it."""
    src, command = Path(argv[0]), argv[1:]
    code = src.read_text()
    try:
        build(code, command)
    except (RuntimeError, OSError) as err:
        library_path(code, command).with_suffix(".err").write_text(f"{err}\n")
    finally:
        src.unlink(missing_ok=True)


if __name__ == "__main__":
    _build_main(sys.argv[1:])
