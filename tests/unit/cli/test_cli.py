"""The command line's own surface: no arguments lists the commands, --version, `python -m cvtdesign`."""
import subprocess
import sys
from importlib.metadata import version

from cvtdesign.cli import main
from cvtdesign.cli.parser import COMMANDS


def test_no_arguments_lists_every_command(capsys):
    assert main([]) == 0
    out = capsys.readouterr().out
    for name, text in COMMANDS.items():
        assert name in out and text.split()[0] in out


def test_version_is_the_installed_one(capsys):
    try:
        main(["--version"])
    except SystemExit as e:
        assert e.code == 0
    assert capsys.readouterr().out.strip() == f"cvtdesign {version('cvtdesign')}"


def test_python_dash_m_runs_the_same_command():
    r = subprocess.run([sys.executable, "-m", "cvtdesign", "--version"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == f"cvtdesign {version('cvtdesign')}"
