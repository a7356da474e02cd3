"""Compiled model functions: a CasADi Function generated as C, compiled once by the machine's C compiler,
cached on disk and loaded on later runs.

The cache is internal, not the tool's output, so it is written here and not through io/output.py. It is
the folder CVTDESIGN_CACHE, else $XDG_CACHE_HOME/cvtdesign, else ~/.cache/cvtdesign. A library is named by
the SHA-256 of its C source and the compile command, so a changed model, CasADi version or flag never loads
a stale one. Processes that compile the same library at once (Dask workers) take a file lock on its name;
the first compiles to a temporary file and renames it into place (os.replace), the others then find it.

The compiler is $CC, else the first of cc, gcc, clang on the PATH. Without one, the model stays interpreted
(CasADi's virtual machine: the same numbers, slower), and one line on stderr says so once per process.

When to compile (CVTDESIGN_COMPILE):
 * 'auto' (default): `Tiered` evaluates a function interpreted until its interpreted evaluations have
   taken HOT_SECONDS, then compiles it in a separate process and switches to the library once it is in
   the cache. A model used for longer than its compile takes pays for the compile; one used briefly never
   waits for the compiler. A call estimated to take longer than WAIT_SECONDS interpreted waits for the
   library instead. The compiling process is detached: a command that ends first still leaves the
   library for the next run.
 * 'always': compile at first use and wait for it. 'never': stay interpreted.
"""
from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import Callable

import casadi as ca
from filelock import FileLock

FLAGS = ["-O1", "-fPIC", "-shared"]   # -O3 compiles 2–3× longer for no faster model (docs/benchmarks.md)
HOT_SECONDS = 1.0       # interpreted evaluation time of one function after which 'auto' compiles it
WAIT_SECONDS = 3.0      # a call estimated to take longer than this interpreted waits for the compiler
POLICIES = ("auto", "always", "never")

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
    digest = hashlib.sha256("\0".join([code, *command, *FLAGS]).encode()).hexdigest()[:32]
    return cache_dir() / f"{digest}.so"


def build(code: str, command: list[str]) -> Path:
    """The library of `code`: from the cache, else compiled by `command` now (lock, temporary file,
    rename: module docstring). Raises RuntimeError with the compiler's first error line if it fails."""
    lib = library_path(code, command)
    lib.parent.mkdir(parents=True, exist_ok=True)
    with FileLock(str(lib.with_suffix(".lock"))):
        if lib.exists():
            return lib
        with tempfile.TemporaryDirectory(dir=lib.parent, prefix=".build-") as tmp:
            src, out = Path(tmp) / "model.c", Path(tmp) / "model.so"
            src.write_text(code)
            done = subprocess.run([*command, *FLAGS, str(src), "-o", str(out), "-lm"], capture_output=True, text=True)
            if done.returncode != 0:
                lines = done.stderr.splitlines()
                raise RuntimeError(f"{' '.join(command)} failed: "
                                   f"{next((ln for ln in lines if 'error' in ln), lines[0] if lines else '')}")
            os.replace(out, lib)
    return lib


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


def load(lib: Path, name: str) -> ca.Function:
    """The function `name` of a compiled library (with its derivatives, if the library has them)."""
    return ca.external(name, str(lib))


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
        notice(f"compiling failed, the model runs interpreted: {err}")
        return None


def compiled(fn: ca.Function, derivatives: bool = False) -> ca.Function | None:
    """fn as a compiled library (from the cache, else compiled now), or None, with a notice, where there is
    no working compiler."""
    command = compiler()
    if command is None:
        notice("no C compiler found (set CC): the model runs interpreted, several times slower")
        return None
    try:
        return load(build(source(fn, derivatives), command), fn.name())
    except (RuntimeError, OSError) as err:
        notice(f"compiling the model failed, it runs interpreted: {err}")
        return None


class Tiered:
    """A function evaluated interpreted until its compiled library is there (module docstring: when).

    `interpreted` is the function to start with; `written_out()` builds the function to compile: the same
    inputs, outputs and numbers, in nodes that can be code-generated."""

    def __init__(self, interpreted: ca.Function, written_out: Callable[[], ca.Function]):
        self.interpreted = interpreted
        self.written_out = written_out
        self.native: ca.Function | None = None
        self.seconds = 0.0             # interpreted evaluation time so far
        self.per_point = 1e-4          # interpreted seconds a point, as last measured
        self.pending: tuple | None = None    # (code, command, library) of the compile under way
        self.given_up = False
        self.lock = threading.Lock()

    def function(self, points: int) -> ca.Function:
        """The function to evaluate `points` points with: compiled if it is there (or worth waiting for),
        else interpreted."""
        with self.lock:
            if self.native is None and not self.given_up:
                self._advance(points * self.per_point)
            return self.native or self.interpreted

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
            code = source(self.written_out())
            lib = library_path(code, command)
            self.pending = (code, command, build_detached(code, command) if not (wait or lib.exists()) else lib)
        code, command, lib = self.pending
        if lib.with_suffix(".err").exists():
            notice(f"compiling the model failed, it runs interpreted: {lib.with_suffix('.err').read_text().strip()}")
            self.given_up = True
        elif lib.exists() or wait:
            try:
                self.native = load(build(code, command), self.interpreted.name())
            except (RuntimeError, OSError) as err:
                notice(f"compiling the model failed, it runs interpreted: {err}")
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
