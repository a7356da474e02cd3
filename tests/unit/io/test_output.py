"""output.py, the one writer: atomic, umask's mode, unusable targets refused in one line, every OSError one
line, no temporary file left behind, several files all or nothing; and the commands that use it."""
import errno
import json
import os
import stat
from pathlib import Path

import matplotlib
import pytest
import yaml

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from conftest import ROOT  # noqa: E402

from cvtdesign.io import output  # noqa: E402
from cvtdesign.cli import main  # noqa: E402
from cvtdesign.io.output import OutputError, staged, write_file, write_files  # noqa: E402
from cvtdesign.io.plots import save  # noqa: E402
from cvtdesign.design.store import read_case, write_case  # noqa: E402
from cvtdesign.io.units import InputError  # noqa: E402

BOX, EXISTING = ROOT / "variants/box_kim.yaml", ROOT / "variants/existing_kim.yaml"


@pytest.fixture
def umask022():
    old = os.umask(0o022)
    yield
    os.umask(old)


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def leftovers(folder) -> list[str]:
    """Hidden (temporary) files left in `folder`."""
    return sorted(p.name for p in Path(folder).iterdir() if p.name.startswith("."))


def one_line(err: str, *needles):
    assert err.count("\n") == 1 and err.startswith("cvtdesign: error: ") and "Traceback" not in err, err
    for n in needles:
        assert n in err, err


# --- modes -------------------------------------------------------------------------------------------------

@pytest.mark.slow
def test_compare_json_and_png_are_0644_under_umask_022(tmp_path, umask022, capsys):
    assert main(["compare", str(BOX), "--out", str(tmp_path / "plots"), "--json", str(tmp_path / "f.json")]) == 0
    assert mode(tmp_path / "f.json") == 0o644 and mode(tmp_path / "plots" / "box_kim.png") == 0o644
    assert json.loads((tmp_path / "f.json").read_text())["variants"]
    assert leftovers(tmp_path) == [] and leftovers(tmp_path / "plots") == []


def test_parquet_png_text_0644_and_umask_honoured(tmp_path, umask022):
    write_case(tmp_path, "c1", [{"case_id": "c1", "x": 1.0}])
    fig = plt.figure()
    save(fig, tmp_path / "f.png")
    write_file(tmp_path / "a.json", "{}\n", kind="--json")
    assert mode(tmp_path / "cases" / "c1.parquet") == 0o644 and mode(tmp_path / "f.png") == 0o644
    assert mode(tmp_path / "a.json") == 0o644
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    os.umask(0o077)
    write_file(tmp_path / "private.json", b"{}", kind="--json")
    assert mode(tmp_path / "private.json") == 0o600
    # a writer that re-creates the file (its own mode) gets the umask's mode back
    write_file(tmp_path / "x.bin", lambda tmp: (os.unlink(tmp), os.close(os.open(tmp, os.O_CREAT | os.O_WRONLY, 0o777))),
               kind="f")
    assert mode(tmp_path / "x.bin") == 0o600


def test_replaces_a_regular_file_and_follows_a_link_to_one(tmp_path):
    (tmp_path / "a.json").write_text("old")
    write_file(tmp_path / "a.json", "new", kind="--json")
    assert (tmp_path / "a.json").read_text() == "new"
    (tmp_path / "link.json").symlink_to(tmp_path / "a.json")
    write_file(tmp_path / "link.json", "via link", kind="--json")
    assert (tmp_path / "link.json").is_symlink() and (tmp_path / "a.json").read_text() == "via link"


# --- targets refused ---------------------------------------------------------------------------------------

def _targets(tmp_path):
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "dir").mkdir()
    (tmp_path / "dir" / "keep").write_text("kept")
    (tmp_path / "dirlink").symlink_to(tmp_path / "dir")
    (tmp_path / "devlink").symlink_to("/dev/null")
    (tmp_path / "file").write_text("a file")
    return {"fifo": "FIFO", "dir": "is a directory", "dirlink": "is a directory", "devlink": "character device",
            "file/x.json": "file is not a folder"}


@pytest.mark.parametrize("name", ["fifo", "dir", "dirlink", "devlink", "file/x.json"])
def test_cli_refuses_unusable_json_target_in_one_line(tmp_path, capsys, name):
    expected = _targets(tmp_path)[name]
    before = sorted(os.listdir(tmp_path))
    assert main(["compare", str(BOX), "--out", str(tmp_path / "plots"), "--json", str(tmp_path / name)]) == 2
    one_line(capsys.readouterr().err, str(tmp_path / name), expected)
    assert sorted(os.listdir(tmp_path)) == before           # refused before anything was computed or written
    assert stat.S_ISFIFO(os.lstat(tmp_path / "fifo").st_mode) and (tmp_path / "dirlink").is_symlink()
    assert os.listdir(tmp_path / "dir") == ["keep"] and (tmp_path / "file").read_text() == "a file"


@pytest.mark.parametrize("name", ["fifo", "dir", "dirlink", "devlink", "file/x.json"])
def test_writer_refuses_unusable_target(tmp_path, name):
    expected = _targets(tmp_path)[name]
    with pytest.raises(OutputError, match=expected) as e:
        write_file(tmp_path / name, "{}", kind="--json")
    assert isinstance(e.value, InputError) and "\n" not in str(e.value)
    assert leftovers(tmp_path) == [] and os.listdir(tmp_path / "dir") == ["keep"]


def test_folder_options_and_missing_folders(tmp_path, capsys, monkeypatch):
    (tmp_path / "file").write_text("a file")
    assert main(["compare", str(BOX), "--out", str(tmp_path / "file")]) == 2
    one_line(capsys.readouterr().err, "--out", "is not a folder")
    # a typo'd folder of a file is refused, not created
    assert main(["compare", str(BOX), "--json", str(tmp_path / "nonexistent/dir/x.json")]) == 2
    one_line(capsys.readouterr().err, "no folder", "nonexistent/dir")
    assert not (tmp_path / "nonexistent").exists()
    # the tool's own output folders are created
    monkeypatch.chdir(tmp_path)
    write_file("results/a/b/c.json", "{}", kind="--json")
    write_file(tmp_path / "out" / "x" / "y.csv", "a\n", kind="--out")
    assert Path("results/a/b/c.json").read_text() == "{}" and Path("out/x/y.csv").exists()
    with pytest.raises(OutputError, match="no folder"):
        write_file("elsewhere/x.json", "{}", kind="--json")


# --- write errors ------------------------------------------------------------------------------------------

def _fail(code):
    def raiser(*args, **kwargs):
        raise OSError(code, os.strerror(code))
    return raiser


@pytest.mark.parametrize("call", ["write", "fsync"])
def test_full_disk_gives_one_line_and_no_temporary_file(tmp_path, capsys, monkeypatch, call):
    out = tmp_path / "rig.csv"
    out.write_text("old")
    monkeypatch.setattr(output.os, call, _fail(errno.ENOSPC))
    assert main(["rig", str(EXISTING), "--out", str(out)]) == 2
    one_line(capsys.readouterr().err, f"--out {out}: cannot write: no space left on device")
    assert out.read_text() == "old" and leftovers(tmp_path) == []


@pytest.mark.parametrize("code, reason", [(errno.EROFS, "read-only file system"), (errno.EACCES, "permission denied"),
                                          (errno.ENAMETOOLONG, "file name too long")])
def test_every_oserror_is_one_line(tmp_path, monkeypatch, code, reason):
    real = os.open

    def failing_open(path, flags, *args):
        if str(path).startswith(str(tmp_path)) and flags & os.O_CREAT:
            raise OSError(code, os.strerror(code), str(path))
        return real(path, flags, *args)

    monkeypatch.setattr(output.os, "open", failing_open)
    with pytest.raises(OutputError) as e:
        write_file(tmp_path / "a.json", "{}", kind="--json")
    assert str(e.value) == f"--json {tmp_path / 'a.json'}: cannot write: {reason}"
    assert os.listdir(tmp_path) == []


def test_real_permission_and_name_errors(tmp_path):
    long = tmp_path / ("x" * 300 + ".json")
    with pytest.raises(OutputError, match="file name too long"):
        write_file(long, "{}", kind="--json")
    if os.geteuid() != 0:
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o555)
        try:
            with pytest.raises(OutputError, match="permission denied"):
                write_file(ro / "a.json", "{}", kind="--json")
        finally:
            ro.chmod(0o755)
    elif Path("/sys/kernel").is_dir() and not os.access("/sys/cvtdesign-test.json", os.F_OK):
        # root bypasses a 0555 folder; sysfs refuses new files even to root
        with pytest.raises(OutputError, match="cannot write: (permission denied|operation not permitted|read-only)"):
            write_file("/sys/cvtdesign-test.json", "{}", kind="--json")


# --- several files: all or nothing -------------------------------------------------------------------------

def test_two_files_all_or_nothing(tmp_path):
    a, b = tmp_path / "a.yaml", tmp_path / "b.json"
    a.write_text("old a")

    def full(tmp):
        Path(tmp).write_text("half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(OutputError, match=f"{b}: cannot write: no space left on device"):
        write_files({a: "new a", b: full}, kind={a: "variant file", b: "--json"})
    assert a.read_text() == "old a" and not b.exists() and leftovers(tmp_path) == []
    # a refused second target: the first is not touched either
    (tmp_path / "d").mkdir()
    with pytest.raises(OutputError, match="is a directory"):
        write_files({a: "new a", tmp_path / "d": "x"}, kind="f")
    assert a.read_text() == "old a" and leftovers(tmp_path) == []
    write_files({a: "new a", b: b"{}"}, kind="f")
    assert a.read_text() == "new a" and b.read_text() == "{}"


def test_failed_rename_puts_back_the_files_already_renamed(tmp_path, monkeypatch):
    a, b = tmp_path / "a", tmp_path / "b"
    a.write_text("old a")
    real = os.replace

    def replace(src, dst):
        if Path(dst) == b:
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        return real(src, dst)

    monkeypatch.setattr(output.os, "replace", replace)
    with pytest.raises(OutputError, match="input/output error"):
        write_files({a: "new a", b: "new b"}, kind="f")
    assert a.read_text() == "old a" and not b.exists() and leftovers(tmp_path) == []


def test_staged_block_failure_and_interrupt_leave_nothing(tmp_path):
    paths = [tmp_path / "x.step", tmp_path / "x.svg"]
    with pytest.raises(OutputError, match="x.svg: cannot write"):
        with staged(paths, kind="CAD file") as tmps:
            tmps[0].write_text("step")
            raise OSError(errno.ENOSPC, "No space left on device", str(tmps[1]))
    with pytest.raises(KeyboardInterrupt):
        with staged(paths, kind="CAD file") as tmps:
            tmps[0].write_text("step")
            raise KeyboardInterrupt
    assert os.listdir(tmp_path) == []
    with staged(paths, kind="CAD file") as tmps:
        for t in tmps:
            t.write_text(t.suffix)
    assert [p.read_text() for p in paths] == [".step", ".svg"]


@pytest.mark.slow
def test_optimise_variant_and_json_all_or_nothing(tmp_path, capsys, monkeypatch):
    """The optimum's variant file is written only together with the --json report."""
    study = tmp_path / "s.yaml"
    study.write_text(yaml.safe_dump({
        "name": "t", "base": str(BOX), "design": {"d": {"lower": "30 mm", "upper": "110 mm"}},
        "envelope": {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                     "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "2 N*m"}},
        "multistart": {"starts": 1}}))
    real = os.write

    def write(fd, data):            # the disk fills up while the JSON report is written
        if os.readlink(f"/proc/self/fd/{fd}").endswith(".json"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd, data)

    monkeypatch.setattr(output.os, "write", write)
    res = tmp_path / "res"
    assert main(["optimise", str(study), "--out", str(res), "--json", str(tmp_path / "o.json")]) == 2
    one_line(capsys.readouterr().err, f"--json {tmp_path / 'o.json'}: cannot write: no space left on device")
    assert list(res.iterdir()) == [] and not (tmp_path / "o.json").exists() and leftovers(tmp_path) == []
    monkeypatch.setattr(output.os, "write", real)
    assert main(["optimise", str(study), "--out", str(res), "--json", str(tmp_path / "o.json")]) == 0
    vfile = json.loads((tmp_path / "o.json").read_text())["variant_file"]
    assert [p.name for p in res.iterdir()] == [Path(vfile).name]


def test_stale_temporary_files_are_recognised(tmp_path):
    stale = tmp_path / ".c1.parquet.0123abcd.tmp.parquet"
    stale.write_text("half")
    (tmp_path / ".lock").write_text("")
    write_case(tmp_path, "c1", [{"case_id": "c1"}])
    assert output.remove_stale_temps(tmp_path) == 1 and leftovers(tmp_path) == [".lock"]
    with pytest.raises(ValueError, match="no column"):
        read_case(tmp_path / "cases" / "c1.parquet")


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc (a folder no file can be made in)")
@pytest.mark.parametrize("argv", [
    ["compare", "{existing}", "--out", "{tmp}/o", "--json", "/proc/nope.json"],
    ["compare", "{existing}", "--out", "{tmp}/o", "--report", "/proc/nope.html"],
    ["diagnose", "{tmp}/d.csv", "--variant", "{existing}", "--plots", "{tmp}/o", "--json", "/proc/nope.json"]])
def test_a_folder_that_takes_no_file_is_refused_before_any_work(tmp_path, capsys, argv):
    """--json into an existing folder where no file can be made (here /proc) used to be found out only at the
    end: diagnose ran its whole diagnosis and wrote its plots, compare wrote its figure and JSON, then exit 2."""
    from conftest import variant_path
    from cvtdesign.cli import main
    (tmp_path / "d.csv").write_text("gamma_cmd_deg,omega_1,omega_2,tau_1,tau_2\n0,10,0,0,0\n")
    args = [a.format(existing=variant_path("existing_kim"), tmp=tmp_path) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "/proc/nope." in err and ": cannot write: " in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.csv"]


def test_the_writability_probe_leaves_nothing(tmp_path):
    out = tmp_path / "r.json"
    assert output.check_target(out, kind="--json", probe=True) == out
    assert output.check_folder(tmp_path, kind="--out", probe=True) == tmp_path
    assert list(tmp_path.iterdir()) == []
