"""`cvtdesign rig`: the virtual test rig, measured-like data from the full model."""
from __future__ import annotations

import dataclasses

from rich.console import Console

from cvtdesign.cli.arguments import effects_arg
from cvtdesign.cli.printing import left_out_text
from cvtdesign.diagnosis import rig
from cvtdesign.errors import InputError
from cvtdesign.io.output import write_file
from cvtdesign.io.schema import MAX_COUNT
from cvtdesign.io.variant import load_variant


def run(args):
    if args.replicates is not None and not 1 <= args.replicates <= MAX_COUNT:
        raise InputError(f"--replicates: expected from 1 to {MAX_COUNT} replicates of each operating point, "
                         f"got {args.replicates}")
    if args.no_axis and args.noise and any(item.split("=")[0].strip() == "axis" for item in args.noise.split(",")):
        raise InputError("--noise: axis=… sets the noise of the axis angle, which --no-axis leaves unrecorded; "
                         "expected one of them")
    layout = load_variant(args.variant)
    effects = effects_arg(args.effects, layout.effects, "--effects")
    params = rig.parse_settings(args.set, effects)
    protocol = rig.read_protocol(args.protocol, layout, args.seed) if args.protocol else rig.kim_protocol(layout)
    if args.replicates is not None:
        protocol = dataclasses.replace(protocol, replicates=args.replicates)
    noise = rig.parse_noise(args.noise)
    rows, failed = rig.simulate(layout, effects, params, protocol, noise, args.seed, axis=not args.no_axis)
    write_file(args.out, rig.to_csv_text(rows), kind="--out")
    console = Console()
    console.print(f"{len(rows)} rows ({protocol.replicates} replicate(s)) of {layout.name} with "
                  f"{', '.join(effects) or 'no effects'} written to {args.out}; noise σ: speed {noise.speed:g} rad/s, "
                  f"torque {noise.torque:g} N·m, axis {noise.axis * 57.29577951308232:g}°")
    if failed:
        console.print(f"[yellow]operating points not measured (the model's physics stops there): "
                      f"{left_out_text(failed)}[/yellow]")
    return 0
