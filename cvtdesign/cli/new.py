"""`cvtdesign new`: write a commented variant file to start from (io.template), from a shipped template,
optionally with N steering rollers (`--steering N`, on the box template)."""
from __future__ import annotations

from cvtdesign.io.template import write_new_variant


def run(args):
    template = args.template or ("box" if args.steering is not None else "existing")
    path = write_new_variant(args.name, template, args.out, args.steering)
    made = f"the '{template}' template" + (f" with {args.steering} steering rollers" if args.steering is not None else "")
    print(f"wrote {path} (from {made}); check it with: cvtdesign compare {path}")
    return 0
