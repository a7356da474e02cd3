"""`cvtdesign new`: write a commented variant file to start from (io.template), from a shipped template."""
from __future__ import annotations

from cvtdesign.io.template import write_new_variant


def run(args):
    path = write_new_variant(args.name, args.template, args.out)
    print(f"wrote {path} (from the '{args.template}' template); check it with: cvtdesign compare {path}")
    return 0
