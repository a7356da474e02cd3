"""The one writer for every file the tool writes (JSON, CSV, plots, case files, variant files, CAD files).

Every write goes to a temporary file beside its target (same folder, a hidden name `.<name>.<hex>.tmp<suffix>`),
which is written, fsynced and only then renamed onto the target, so a reader sees the old file or the new
one, never half of one. Several files that make one output (a STEP + SVG + PNG export; an optimum's variant
file and its JSON report) are written with `write_files` or `staged`: every temporary file is written
first and only then are they renamed, so on any failure none of the targets is touched.

Rules:
* A target that exists and is not a regular file (a directory, a device, a FIFO, a socket, or a symbolic
  link to one of these, or a broken link) is refused; a path under a regular file (`file/x.json`) too.
  A symbolic link to a regular file is followed: the file it points to is replaced, the link kept.
* Missing parent folders are created only inside the tool's own output folders: `out/`, `results/` and
  `cad_out/` below the working directory (OUTPUT_ROOTS), and the folders that a command or function names
  as its output folder (`--out` of compare/optimise/study/export, `--plots`, a study's store), which their
  owners create with `make_folder`. The folder of a file named directly (`--json FILE`, `rig --out FILE`)
  must exist: a typo such as `--json /nonexistent/dir/x.json` is refused, not created.
* New files get the process umask's mode (0644 under umask 022): the temporary file is created by
  `os.open(..., 0o666)`, so the umask applies (not mkstemp's 0600), and a writer that re-creates the file
  gets that mode back before the rename.
* Every OSError (a directory, permission denied, a full disk, a read-only file system, a name too long, ...)
  becomes one `OutputError` line naming the path and the reason; the temporary files are removed on any
  failure, Ctrl-C included. OutputError is an InputError, so the command prints it as one line and exits
  with status 2.
"""
from __future__ import annotations

import contextlib
import os
import re
import secrets
import stat
import zlib
from pathlib import Path

from cvtdesign.errors import InputError

OUTPUT_ROOTS = ("out", "results", "cad_out")
_TEMP = re.compile(r"^\..*\.[0-9a-f]{8}\.(tmp|bak)")     # the names of this module's temporary files


class OutputError(InputError):
    """A file could not be written: one line naming the path and the reason (exit status 2)."""


def _reason(e: OSError) -> str:
    """The OSError's reason in words ('no space left on device')."""
    text = e.strerror or str(e)
    return text[:1].lower() + text[1:]


def _error(path, kind: str, e: OSError) -> OutputError:
    return OutputError(f"{kind} {path}: cannot write: {_reason(e)}")


def _what(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def _not_a_folder(path: Path) -> Path | None:
    """The nearest existing ancestor of `path` that is not a folder (`file` for `file/x/y`), or None."""
    for p in [path, *path.parents]:
        if os.path.lexists(p):
            return None if p.is_dir() else p
    return None


def _probe(folder: Path, path: Path, kind: str) -> None:
    """Refuse a folder that exists but cannot take a new file (read-only, /proc, no space): create an empty
    hidden file in it and remove it, so the refusal comes before any computation and nothing is left."""
    try:
        tmp, _ = _new_temp(folder / ".cvtdesign-probe", kind, "probe")
    except OutputError as e:
        raise OutputError(f"{kind} {path}: cannot write: {str(e).rsplit(': ', 1)[-1]}") from None
    tmp.unlink(missing_ok=True)


def _in_roots(folder: Path) -> bool:
    """Whether `folder` is one of the tool's own output folders (OUTPUT_ROOTS below the working directory)."""
    here = Path(os.path.abspath(folder))
    cwd = Path.cwd()
    return any(here == cwd / r or cwd / r in here.parents for r in OUTPUT_ROOTS)


def check_folder(folder, *, kind: str, probe: bool = False) -> Path:
    """Refuse an output folder that cannot be one (it exists and is not a folder, or lies under a file, or,
    with `probe`, takes no new file: `_probe`); leaves nothing. Returns it as a Path."""
    folder = Path(folder)
    blocker = _not_a_folder(folder)
    if blocker is not None:
        what = "is not a folder" if blocker == folder else f"lies under {blocker}, which is not a folder"
        raise OutputError(f"{kind} {folder}: {what}; expected a folder or a new folder name")
    if probe and folder.is_dir():
        _probe(folder, folder, kind)
    return folder


NAME_MAX = 60      # characters of the input files' stems in an output's name (`named_after`)


def named_after(inputs, suffix: str) -> str:
    """An output's file name after the input files it is made of, so that runs on other inputs do not
    overwrite it: '<stem><suffix>' for one file ('box.png'), the stems in sorted order joined by '+' for
    several ('box+existing+unequal.png', whatever order they were given in); past NAME_MAX characters the
    first two stems, how many more, and a checksum of all the stems ('box+box+3_more-5f1c2a.png')."""
    stems = sorted(Path(f).stem for f in inputs)
    joined = "+".join(stems)
    if len(joined) > NAME_MAX:
        joined = f"{stems[0]}+{stems[1]}+{len(stems) - 2}_more-{zlib.crc32(joined.encode()):08x}"
    return joined + suffix


def make_folder(folder, *, kind: str) -> Path:
    """Create an output folder the caller owns (with its missing parents, like mkdir -p); one OutputError
    line if it cannot be made. Returns it as a Path."""
    folder = check_folder(folder, kind=kind)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"{kind} {folder}: cannot create the folder: {_reason(e)}") from None
    return folder


def check_target(path, *, kind: str, create: bool = False, probe: bool = False) -> Path:
    """The file to replace for `path` (a symbolic link to a regular file: the file it points to), after
    refusing a target that is not a regular file or lies under one, or whose folder is missing outside the
    tool's own output folders (see the module's rules), or, with `probe`, whose folder takes no new file
    (`_probe`: for the checks before any work; a write finds that out by itself). With `create`, that missing
    folder is made."""
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        st = None
    except OSError as e:
        blocker = _not_a_folder(path.parent)
        if blocker is not None:
            raise OutputError(f"{kind} {path}: {blocker} is not a folder; expected a path inside a folder") from None
        raise _error(path, kind, e) from None
    link = path.is_symlink()
    if st is not None:
        if not stat.S_ISREG(st.st_mode):
            via = f" (the symbolic link points to {os.path.realpath(path)})" if link else ""
            raise OutputError(f"{kind} {path}: is {_what(st.st_mode)}{via}; expected a regular file or a new file name")
        return Path(os.path.realpath(path)) if link else path
    if link:
        raise OutputError(f"{kind} {path}: is a broken symbolic link (to {os.readlink(path)}); expected a regular "
                          "file or a new file name")
    folder = path.parent
    blocker = _not_a_folder(folder)
    if blocker is not None:
        raise OutputError(f"{kind} {path}: {blocker} is not a folder; expected a path inside a folder")
    if not folder.is_dir():
        if not _in_roots(folder):
            raise OutputError(f"{kind} {path}: no folder {folder}; expected an existing folder (only the tool's "
                              f"own output folders {', '.join(r + '/' for r in OUTPUT_ROOTS)} are created)")
        if create:
            make_folder(folder, kind=kind)
    elif probe:
        _probe(folder, path, kind)
    return path


def _new_temp(target: Path, kind: str, tag: str = "tmp") -> tuple[Path, int]:
    """Create an empty hidden file beside `target` with mode 0o666 & ~umask; returns (path, its mode)."""
    for _ in range(100):
        tmp = target.with_name(f".{target.name[:80]}.{secrets.token_hex(4)}.{tag}{target.suffix[:16]}")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        except FileExistsError:
            continue
        except OSError as e:
            raise _error(target, kind, e) from None
        try:
            return tmp, stat.S_IMODE(os.fstat(fd).st_mode)
        finally:
            os.close(fd)
    raise OutputError(f"{kind} {target}: cannot write: no free temporary name beside it")


def _finish(tmp: Path, mode: int):
    """Give a written temporary file its mode back (a writer may have re-created it) and fsync it."""
    if stat.S_IMODE(os.stat(tmp).st_mode) != mode:
        os.chmod(tmp, mode)
    fd = os.open(tmp, os.O_RDONLY | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _sync_folders(targets):
    """fsync the folders of renamed files (best effort: some file systems cannot sync a directory)."""
    for folder in {t.parent for t in targets}:
        with contextlib.suppress(OSError):
            fd = os.open(folder, os.O_RDONLY | os.O_CLOEXEC)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)


def _backup(target: Path) -> Path | None:
    """A hard link to the existing target (to restore it if a later rename of the same output fails), or
    None when there is no target or the file system has no hard links."""
    if not target.exists():
        return None
    bak = target.with_name(f".{target.name[:80]}.{secrets.token_hex(4)}.bak{target.suffix[:16]}")
    try:
        os.link(target, bak)
        return bak
    except OSError:
        return None


def _rename_all(pairs: list[tuple[Path, Path, str, str]]):
    """Rename every (temporary, target) pair; if one fails, put back the targets already renamed."""
    done, backups = [], []
    try:
        for tmp, target, shown, kind in pairs:
            bak = _backup(target) if len(pairs) > 1 else None
            backups.append(bak)
            try:
                os.replace(tmp, target)
            except OSError as e:
                raise _error(shown, kind, e) from None
            done.append((target, bak))
    except BaseException:
        for target, bak in reversed(done):
            with contextlib.suppress(OSError):
                os.replace(bak, target) if bak else os.unlink(target)
        raise
    finally:
        for bak in backups:
            if bak is not None and os.path.lexists(bak):
                with contextlib.suppress(OSError):
                    os.unlink(bak)
    _sync_folders([t for _, t, _, _ in pairs])


def _kinds(kind, paths: list[Path]) -> list[str]:
    """What each file is, for messages: `kind` is one text for all, or a mapping path → text."""
    if isinstance(kind, str):
        return [kind] * len(paths)
    by_path = {Path(p): k for p, k in kind.items()}
    return [by_path.get(p, "output file") for p in paths]


@contextlib.contextmanager
def staged(paths, *, kind):
    """Yield one temporary path beside each target (created empty, mode 0o666 & ~umask) for the block to
    write; when the block succeeds, every temporary file is fsynced and only then are they all renamed onto
    their targets. On any failure (the block's included) the temporary files are removed and no target is
    touched. An OSError of the block about a temporary file becomes an OutputError naming its target.
    kind: what the files are, for messages (one text, or {path: text})."""
    paths = [Path(p) for p in paths]
    kinds = _kinds(kind, paths)
    targets = [check_target(p, kind=k, create=True) for p, k in zip(paths, kinds)]
    temps = []
    try:
        for target, k in zip(targets, kinds):
            temps.append(_new_temp(target, k))
        tmp_paths = [t for t, _ in temps]
        try:
            yield tmp_paths
        except OSError as e:
            hit = [i for i, t in enumerate(tmp_paths) if e.filename is not None and os.fsdecode(e.filename) == str(t)]
            if e.filename is not None and not hit:
                raise
            i = hit[0] if hit else 0
            raise _error(paths[i], kinds[i], e) from None
        for (tmp, mode), p, k in zip(temps, paths, kinds):
            try:
                _finish(tmp, mode)
            except OSError as e:
                raise _error(p, k, e) from None
        _rename_all([(tmp, target, p, k) for (tmp, _), target, p, k in zip(temps, targets, paths, kinds)])
    finally:
        for tmp, _ in temps:
            if os.path.lexists(tmp):
                with contextlib.suppress(OSError):
                    os.unlink(tmp)


def _write_data(tmp: Path, data):
    """Write bytes or text (UTF-8) to the (empty) temporary file, or let `data(tmp)` write it."""
    if callable(data):
        data(tmp)
        return
    view = memoryview(data.encode("utf-8") if isinstance(data, str) else bytes(data))
    fd = os.open(tmp, os.O_WRONLY | os.O_TRUNC | os.O_CLOEXEC)
    try:
        while view:
            view = view[os.write(fd, view):]
    finally:
        os.close(fd)


def write_files(files: dict, *, kind) -> list[Path]:
    """Write several files all or nothing: {path: data}, data bytes, str (UTF-8) or a callable that writes
    the temporary path it is given (e.g. `lambda tmp: fig.savefig(tmp)`). Every file is written and
    fsynced first, then all are renamed. kind: what the files are, for messages (one text, or
    {path: text}). Returns the paths."""
    paths = [Path(p) for p in files]
    kinds = _kinds(kind, paths)
    with staged(paths, kind=dict(zip(paths, kinds))) as temps:
        for path, k, data, tmp in zip(paths, kinds, files.values(), temps):
            try:
                _write_data(tmp, data)
            except OSError as e:
                raise _error(path, k, e) from None
    return paths


def write_file(path, data, *, kind: str) -> Path:
    """Write one file atomically (see the module's rules): data bytes, str (UTF-8) or a callable that
    writes the temporary path it is given. kind: what the file is, for messages ('--json', 'plot', ...)."""
    return write_files({Path(path): data}, kind=kind)[0]


def remove_stale_temps(folder) -> int:
    """Remove the temporary files this module left in `folder` when a process was killed mid-write (call
    it only while no other process writes there, e.g. under a store's lock). Returns how many."""
    n = 0
    for p in Path(folder).glob(".*"):
        if _TEMP.match(p.name) and p.is_file():
            with contextlib.suppress(OSError):
                p.unlink()
                n += 1
    return n
