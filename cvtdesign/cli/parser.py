"""The `cvtdesign` command line: its arguments, and `main`, which runs the command module (cvtdesign.cli.<name>)."""
from __future__ import annotations

import argparse
import contextlib
import functools
import gc
import importlib
import os
import signal
import sys
import threading
from importlib.metadata import version

from cvtdesign.cli.options import check_options
from cvtdesign.errors import InputError, RunError
from cvtdesign.io.output import check_folder, check_target
from cvtdesign.io.shipped import SHIPPED


class _Parser(argparse.ArgumentParser):
    """argparse with its errors as one line (no usage block): 'cvtdesign rig: error: argument --seed: invalid
    int value: 'x' (see cvtdesign rig --help)', exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")


COMMANDS = {     # name -> one-line help; cvtdesign.cli.<name> runs it
    "new": "write a commented variant file from a template (existing, box or unequal) to start from",
    "show": "draw a variant's layout (sphere, rollers, axles, forks, frames) and print its ideal law",
    "compare": "evaluate variants over their envelope and print a side-by-side table",
    "capacity": "the largest load τ⊥ at each γ before |α| passes a usable bound, the ratio runs away, or a contact "
                "slips grossly, loses contact or is over its pressure",
    "optimise": "optimise a variant's parameters under slip/efficiency objectives (IPOPT)",
    "study": "run a study's cases (sweeps, multistarts, Pareto fronts) in batch on Dask",
    "export": "write the variant's assembly as STEP (+ SVG, PNG) for mechanical review",
    "contact": "each roller's contact patch (Hertz, Kalker's coefficients) and its creep–force curves",
    "rig": "virtual test rig: measured-like data (the measured-data CSV format) from the full model",
    "diagnose": "where the model and the data disagree, which effect causes it, how far it shrinks",
    "resteer": "steering commands for requested speed ratios under a known load (Brokowski sec. 5)",
    "selfcheck": "prove the diagnosis on rig data with withheld effects; exit 1 if a target is missed",
    "cache": "show the compiled-model cache (its folder and size), or empty it with --clear",
    "tolerance": "Monte Carlo over a variant's manufacturing tolerances on Dask, against the first-order prediction",
    "life": "heat, wear and life of every contact over a duty cycle, and which contact limits the machine",
    "transient": "transient steering dynamics: a step of the command, the fastest ratio change, the bandwidth and "
                 "the ratio error while rendering a constraint",
}

# Short commands that draw one figure. A plotting process (args.painter, an io.plots.Background) draws it, started
# before the command's module is imported, so that it imports matplotlib while the command imports its libraries
# and computes. They run without Python's cyclic garbage collector, whose passes would walk every object the
# imports made (30 ms each) for the little garbage such a run leaves; and when the command is the process's
# (main's argv None), its objects are frozen at the end, so that the interpreter's exit does not walk them either.
SHORT_WITH_FIGURE = ("compare",)


@functools.cache
def build_parser():
    """The command line's parser, built once per process (parsing leaves it as it was)."""
    p = _Parser(prog="cvtdesign", description="Design, optimise, compare and diagnose spherical CVTs.",
                epilog="`cvtdesign COMMAND --help` describes a command; docs/ has the rest.")
    p.add_argument("--version", action="version", version=f"%(prog)s {version('cvtdesign')}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    adders = {"new": _add_new, "show": _add_show, "compare": _add_compare, "optimise": _add_optimise,
              "study": _add_study, "export": _add_export, "contact": _add_contact, "rig": _add_rig, "diagnose": _add_diagnose,
              "resteer": _add_resteer, "selfcheck": _add_selfcheck, "cache": _add_cache}
    adders["capacity"] = _add_capacity
    adders["tolerance"] = _add_tolerance
    adders["life"] = _add_life
    adders["transient"] = _add_transient
    for name, text in COMMANDS.items():
        adders[name](sub.add_parser(name, help=text, description=text))
    return p


def command_actions(command: str) -> list:
    """The argparse actions of `command`'s arguments (its options and positional arguments)."""
    return build_parser()._subparsers._group_actions[0].choices[command]._actions


def _add_new(p):
    p.add_argument("name", help="the variant's name (letters, digits, '_', '.', '+', '-'); the file is NAME.yaml")
    p.add_argument("--template", choices=SHIPPED,
                   help="layout to start from (default: existing, Kim's two-steering-roller CVT; box with --steering)")
    p.add_argument("--steering", type=int, metavar="N",
                   help="N steering rollers (2, 3 or 4) at the poles on forks about the pole axis, with the box "
                   "template's drive and follower rollers (docs/linkages.md)")
    p.add_argument("--out", help="file to write (default: NAME.yaml in the current folder; never overwritten)")


def _add_show(p):
    p.add_argument("variant", help="variant YAML file")
    p.add_argument("--gamma", type=float, help="commanded γ [deg] the forks are drawn at (default 45, as export's)")
    p.add_argument("--out", default="out/show", help="folder for <file stem>_layout.png (<file stem>_layout_gamma<γ>.png "
                   "at another γ; default folder: out/show)")


def _add_compare(p):
    p.add_argument("variants", nargs="+", help="variant YAML files")
    p.add_argument("--out", default="out/compare", help="folder for the figure, named after the variant files "
                   "(<stems joined by +>.png; default folder: out/compare)")
    p.add_argument("--json", help="also write the figures to this JSON file")
    p.add_argument("--report", help="also write an HTML report (the tables and the plot) to this file")
    p.add_argument("--points", metavar="FILE.csv|FILE.parquet",
                   help="also write every contact's state at every operating point (one row per variant, point "
                        "and contact; columns in docs/comparing.md), as CSV or Parquet by the extension")
    p.add_argument("--envelope", metavar="VARIANT.yaml",
                   help="evaluate every column on this file's envelope (default: the first file's)")
    p.add_argument("--duty", help="a duty-cycle file (docs/life.md): adds each variant's life on it, its limit and "
                                  "contact (cvtdesign life gives the details and the intervals)")
    p.add_argument("--as-written", action="store_true",
                   help="evaluate each file as written, on its own envelope and contact law (refused otherwise "
                        "when the laws differ); each column then says what it used")
    p.add_argument("--samples", type=int, default=None,
                   help="samples of every uncertain input that check each first-order interval; an interval they "
                        "do not confirm (within 10%% of its width) is replaced by theirs (default 128 where the "
                        "envelope has at most 2000 points, else 0; 0: first order only, unchecked)")


def _add_capacity(p):
    p.add_argument("variants", nargs="+", help="variant YAML files (each on its own envelope's γ)")
    p.add_argument("--json", help="also write the capacities to this JSON file (format in docs/capacity.md)")
    p.add_argument("--plots", help="folder for <file stems joined by +>_capacity.png: capacity against γ, the "
                                   "envelope drawn in, each point marked by its limit and contact")
    p.add_argument("--safety", type=float, default=1.0,
                   help="safety factor S ≥ 1 on friction: a contact counts as slipping grossly once its "
                        "utilisation F/(μN) reaches 1/S (default 1)")
    p.add_argument("--max-slip", metavar="ANGLE",
                   help="usable-ratio bound: the capacity ends where the CVT slip angle |α| passes it (default "
                        "2deg, about 10%% speed-ratio error at ratios 0.4 and 2.5; 90deg: no bound; a plain "
                        "number is in rad)")
    p.add_argument("--samples", type=int, default=0,
                   help="samples of every uncertain input that check each capacity's first-order interval, each "
                        "a whole search (default 0: first order only; a runaway's interval is always sampled)")


def _add_life(p):
    p.add_argument("variants", nargs="+", help="variant YAML files")
    p.add_argument("--duty", required=True, help="duty-cycle YAML file: operating points with their share of time, "
                   "or a task log (docs/life.md; studies/cobot_duty.yaml)")
    p.add_argument("--json", help="also write each variant's and contact's life to this JSON file (format in "
                                  "docs/life.md)")
    p.add_argument("--plots", help="folder for <file stems joined by +>_temperature.png (each roller's temperature "
                                   "over the cycle) and _life.png (each contact's life with its interval)")
    p.add_argument("--report", help="also write an HTML report (the tables and both figures) to this file")


def _add_transient(p):
    p.add_argument("variants", nargs="+", help="variant YAML files (their dynamics: section gives the inertias and "
                                               "the steering motor; docs/dynamics.md)")
    p.add_argument("--gamma-from", metavar="ANGLE", help="the step's commanded γ before it, e.g. '10 deg' (default "
                   "10 deg; a plain number is in rad), and where the ramp and the rendered profile start")
    p.add_argument("--gamma-to", metavar="ANGLE", help="the step's commanded γ after it (default 40 deg)")
    p.add_argument("--load", metavar="TORQUE", help="the lateral load τ⊥ held throughout, e.g. '0.5 N*m' (default: "
                   "half the envelope's largest |τ⊥|, 0.5 N*m on the shipped ±1 N*m envelopes)")
    p.add_argument("--bandwidth-at", metavar="ANGLES", help="the commanded γ of the bandwidth's operating points, "
                   "comma-separated, at that load (default '10 deg,25 deg,40 deg')")
    p.add_argument("--render-hz", type=float, metavar="HZ", help="the frequency [Hz] of the rendered ratio profile, "
                   "swinging between the ideal ratios of --gamma-from and --gamma-to (default 1)")
    p.add_argument("--quick", action="store_true", help="leave out the fastest-ratio-change search and the "
                   "rendering (the long parts: seconds a variant); their figures are null, with why")
    p.add_argument("--json", help="also write the figures to this JSON file (format in docs/dynamics.md)")
    p.add_argument("--plots", help="folder for <file stems joined by +>_step.png, _bode.png and _render.png")
    p.add_argument("--report", help="also write an HTML report (the table and the figures) to this file")


def _add_optimise(p):
    p.add_argument("study", help="study YAML file (studies/*.yaml)")
    p.add_argument("--out", help="folder for the optimised variant (default: results/<study name>)")
    p.add_argument("--starts", type=int, help="number of multistart points (default: the study's)")
    p.add_argument("--json", help="also write the result to this JSON file")
    p.add_argument("--report", help="also write an HTML report (the design and constraint tables) to this file")
    p.add_argument("--step", action="store_true", help="also export the optimum as a STEP assembly (+ SVG, PNG)")
    p.add_argument("--calibration", metavar="FITTED.json", help="a diagnosis report (cvtdesign diagnose --json): "
                   "the base variant carries its fitted effect parameters (under a contact law without fitted "
                   "creep constants, the calibration of its theory's compliances)")


def _add_study(p):
    p.add_argument("study", help="study YAML file (studies/*.yaml)")
    p.add_argument("--out", help="results store (default: results/<study name>)")
    p.add_argument("--scheduler", help="address of an existing Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=int, help="local cluster size (default: one single-threaded worker per core)")
    p.add_argument("--step", action="store_true",
                   help="also export the best optimum of each variant/sweep point and every Pareto point as STEP")


def _add_rig(p):
    p.add_argument("variant", help="variant YAML file")
    p.add_argument("--effects", help="effects on, comma-separated (default: the variant's; 'none' for the ideal CVT)")
    p.add_argument("--set", action="append", metavar="EFFECT.PARAM=VALUE",
                   help="an effect parameter, e.g. a creep scale EFFECT.scale=1.2 or a length with its unit "
                        "'EFFECT.offset=0.2 mm' (the effects and their parameters: docs/effects.md)")
    p.add_argument("--noise", help="measurement noise σ, e.g. 'speed=0.01 rad/s,torque=0.005 N*m,axis=0.05 deg' "
                                   "(these are the defaults; plain numbers are SI)")
    p.add_argument("--protocol", help="protocol YAML (gamma, load, load_kind, motor_speed, replicates, random, seed), "
                                      "or 'random' (Kim's ranges, 187 points drawn at random with --seed); default Kim's")
    p.add_argument("--replicates", type=int, help="repeat every operating point this many times")
    p.add_argument("--seed", type=int, default=0, help="random seed of the noise (default 0)")
    p.add_argument("--no-axis", action="store_true", help="do not record the axis angle gamma_axis_deg")
    p.add_argument("--out", required=True, help="CSV file to write")


def _add_diagnose(p):
    p.add_argument("data", help="measured data CSV (columns gamma_cmd_deg, omega_1, omega_2, tau_1, tau_2 [, gamma_axis_deg])")
    p.add_argument("--variant", required=True, help="variant YAML file the data was measured on")
    p.add_argument("--base", help="effects of the model to diagnose, comma-separated (default: the variant's)")
    p.add_argument("--candidates", help="candidate effects to try (default: every effect not in the base)")
    p.add_argument("--drop-bad", action="store_true", help="drop (and count) bad rows instead of stopping")
    p.add_argument("--json", help="write the report to this JSON file")
    p.add_argument("--plots", help="folder for the residual-map and fit plots")
    p.add_argument("--report", help="also write an HTML report (the tables, the residual map and the fit) to this file")
    p.add_argument("--save-calibration", metavar="FILE.yaml",
                   help="write the fitted drive and steering compliances as calibrations of the rollers' materials "
                        "on the sphere's, in the materials library's format (an existing library file keeps its "
                        "other entries); a variant uses it with material_library: [FILE.yaml]")


def _add_selfcheck(p):
    p.add_argument("--variant", help="variant of the rig matrix (default: variants/existing_kim.yaml)")
    p.add_argument("--matrices", help="comma-separated: rig (the project's own model makes the data), independent "
                                      "(an independently written simulator of Kim's CVT); default: both")
    p.add_argument("--quick", action="store_true", help="a reduced matrix (one value and noise level per effect)")
    p.add_argument("--seeds", type=int, default=3, help="null datasets per noise level / 2 (default 3)")
    p.add_argument("--scheduler", help="address of an existing Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=int, help="local cluster size (default: one worker per core)")
    p.add_argument("--only", help="run only the datasets whose id contains one of these comma-separated texts")
    p.add_argument("--json", help="write the per-dataset results and the summary to this JSON file")


def _add_resteer(p):
    p.add_argument("data", nargs="?", help="measured data CSV: fit the model to it and add the inverted data lookup; "
                                           "or, without data, the variant YAML file")
    p.add_argument("--variant", help="variant YAML file (with measured data)")
    p.add_argument("--effects", help="effects of the model (default: the variant's)")
    p.add_argument("--load", help="lateral load τ⊥, e.g. '1 N*m' (default: the data's highest load level)")
    p.add_argument("--ratios", help="requested ω2/ω1, comma-separated (default Brokowski's 0.4,0.5,0.8,1,1.25,2,2.5)")
    p.add_argument("--truth-effects", help="score each command on the virtual rig with these effects (eq 23)")
    p.add_argument("--truth-set", action="append", metavar="EFFECT.PARAM=VALUE", help="a parameter of the rig's effects")
    p.add_argument("--drop-bad", action="store_true", help="drop (and count) bad data rows instead of stopping")
    p.add_argument("--json", help="write the commands and scores to this JSON file")
    p.add_argument("--plots", help="folder for the Fig. 17-style plot")
    p.add_argument("--table", metavar="FILE.csv", help="write the controller table instead: γ_cmd over a (ratio, "
                   "τ⊥) grid, with the ideal command and the residual ratio error (format in docs/diagnosis.md)")
    p.add_argument("--table-ratios", metavar="LIST|START:STOP:COUNT",
                   help="the table's ratios ω2/ω1 (default: the ideal ratio at each γ of the envelope)")
    p.add_argument("--table-loads", metavar="LIST|START:STOP:COUNT",
                   help="the table's loads τ⊥, e.g. '-1 N*m:1 N*m:21' (default: the envelope's loads)")


def _add_export(p):
    p.add_argument("variant", help="variant YAML file")
    p.add_argument("--out", default="cad_out", help="folder for <file stem>.step/.svg/.png (default: cad_out)")
    p.add_argument("--gamma", type=float, default=45.0, help="commanded γ [deg] the forks are turned for (default 45)")
    p.add_argument("--check", action="store_true", help="re-read the STEP file and check names, validity, contacts, "
                   "interference and bounding box (exit status 1 if a check fails)")


def _add_contact(p):
    p.add_argument("variant", help="variant YAML file")
    p.add_argument("--json", help="write every roller's contact and its creep–force curves to this JSON file")
    p.add_argument("--plots", help="folder for <file stem>_contact_curves.png and <file stem>_contact_patches.png")


def _add_tolerance(p):
    p.add_argument("variant", help="variant YAML file")
    p.add_argument("--tolerances", required=True, metavar="FILE.yaml",
                   help="the toleranced dimensions and their distributions (docs/tolerances.md; e.g. studies/box_tolerances.yaml)")
    p.add_argument("--samples", type=int, default=200, help="Monte Carlo samples (default 200)")
    p.add_argument("--dimensions-only", action="store_true", help="sample the toleranced dimensions alone (default: "
                   "the variant's physical inputs too: calibration, preload, moduli, friction, the law's own error)")
    p.add_argument("--json", help="also write the figures' distributions, first-order predictions and effects to this JSON file")
    p.add_argument("--plots", help="folder for <variant stem>_<tolerances stem>_tolerance.png")
    p.add_argument("--store", help="store of the samples, resumed when run again (default: results/<variant stem>_<name>)")
    p.add_argument("--scheduler", help="address of an existing Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=int, help="local cluster size (default: one single-threaded worker per core)")


def _add_cache(p):
    p.add_argument("--clear", action="store_true", help="remove every compiled model from the cache (each is "
                   "compiled again when next needed)")


INPUTS = ("variant", "variants", "study", "data", "protocol", "calibration", "tolerances", "duty")   # arguments naming files a command reads


def _not_an_input(path: str, kind: str, args) -> None:
    """An output file must not be one of the command's own inputs (`rig v.yaml --out measured.csv --protocol
    measured.csv` would replace the file it reads)."""
    if not os.path.isfile(path):
        return
    for name in INPUTS:
        given = getattr(args, name, None)
        for f in [given] if isinstance(given, str) else given or []:
            if os.path.isfile(f) and os.path.samefile(f, path):
                raise InputError(f"{kind}: {path} is this command's input ({name}); expected another file, so "
                                 "that the input is not overwritten")


def check_outputs(args):
    """Refuse an output path that cannot be written before any computation (each write checks again):
    --json, --report and the --out of rig and new are files, none of them an input of the command; --plots and
    the other commands' --out are folders. Before them, the options as a whole (cli.options.check_options:
    no empty value, no two outputs on one path, no contradicting pair)."""
    check_options(args, command_actions(args.command))
    files = [(k, getattr(args, k[2:].replace("-", "_"), None))
             for k in ("--json", "--report", "--points", "--save-calibration", "--table")]
    if args.command in ("rig", "new"):
        files.append(("--out", getattr(args, "out", None)))
    elif getattr(args, "out", None):
        check_folder(args.out, kind="--out", probe=True)
    for kind in ("--plots", "--store"):
        if getattr(args, kind[2:], None):
            check_folder(getattr(args, kind[2:]), kind=kind, probe=True)
    for kind, path in files:
        if path:
            check_target(path, kind=kind, probe=True)
            _not_an_input(path, kind, args)


TERMINATED: list = []      # the SIGTERMs this process received in main


def _terminate(signum, frame):
    """SIGTERM (`kill`, a batch system's stop) ends a command as Ctrl-C does: the KeyboardInterrupt closes
    what the command opened (a study's cluster) and main prints the same one line (a study's: how many cases
    are kept)."""
    TERMINATED.append(signum)
    raise KeyboardInterrupt


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """`_terminate` handles SIGTERM inside the block (in the main thread only: signals are delivered there)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGTERM, _terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _drop_stdout() -> None:
    """Send what is left of stdout to /dev/null once its reader has closed it (`cvtdesign compare … | head`),
    as rich does, so that Python's flush at exit reports no closed pipe."""
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass


# options whose value may start with '-' ('-1:1:21', '-0.5 N*m', '-10 deg')
MINUS_VALUES = ("--table-ratios", "--table-loads", "--gamma-from", "--gamma-to", "--load", "--bandwidth-at")


def _joined_negative_values(argv) -> list[str]:
    """argv with `--table-loads -1:1:21` read as `--table-loads=-1:1:21`: argparse takes a value starting with
    '-' for an option unless it is a plain negative number."""
    out, argv = [], list(argv)
    for k, a in enumerate(argv):
        if k and argv[k - 1] in MINUS_VALUES and a.startswith("-") and out and out[-1] == argv[k - 1]:
            out[-1] = f"{out[-1]}={a}"
        else:
            out.append(a)
    return out


def main(argv=None) -> int:
    """Run one command; returns its exit status (2 for bad input, with one line on stderr; 130 after Ctrl-C,
    143 after SIGTERM; 1 when stdout's reader closed it, quietly: every command writes its files first)."""
    parser = build_parser()
    args = parser.parse_args(_joined_negative_values(sys.argv[1:] if argv is None else argv))
    args.argv = list(sys.argv[1:] if argv is None else argv)     # the command line, for --report
    if args.command is None:
        parser.print_help()
        return 0
    with _sigterm_as_interrupt():
        return _run(args, argv)


def _command_module(command: str, argv):
    """The one place a command's module (and its libraries: Dask, CadQuery, SciPy) is imported, without the
    cyclic garbage collector: its passes during the imports (SciPy, pandas, pint: 100 000 objects, none of them
    garbage) took 0.12–0.15 s of a 3 s diagnose. When the command is the process's (main's argv None), the objects
    the imports made are then frozen, so that neither the run's collections nor the interpreter's exit (0.05 s)
    walk them. The run gets the collector back if it had it (SHORT_WITH_FIGURE's run without)."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        module = importlib.import_module(f"cvtdesign.cli.{command}")
        if argv is None:
            gc.freeze()
        return module
    finally:
        if collecting:
            gc.enable()


def _run(args, argv) -> int:
    short, collecting, painter = args.command in SHORT_WITH_FIGURE, gc.isenabled(), None
    TERMINATED.clear()
    try:
        check_outputs(args)
        if short:
            gc.disable()
            # imported here, as the command modules are: io.plots loads numpy and CasADi (not matplotlib), which
            # `cvtdesign --help` and `new` need not wait for
            args.painter = painter = importlib.import_module("cvtdesign.io.plots").Background()
        return _command_module(args.command, argv).run(args)
    except InputError as e:
        print(f"cvtdesign: error: {e}", file=sys.stderr)
        return 2
    except RunError as e:
        print(f"cvtdesign: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as e:   # study.Interrupted says how much is kept
        print(f"cvtdesign: {str(e) or 'interrupted'}", file=sys.stderr)
        return 128 + (signal.SIGTERM if TERMINATED else signal.SIGINT)
    except BrokenPipeError:
        _drop_stdout()
        return 1
    finally:
        if painter is not None:
            painter.close()
        if short and argv is None:
            gc.freeze()
        elif short and collecting:
            gc.enable()

