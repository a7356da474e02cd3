"""`cvtdesign export`: a variant's assembly as STEP (+ SVG, PNG) for mechanical review."""
from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.table import Table

from cvtdesign.cad.export import export_variant
from cvtdesign.cli.printing import progress_bar
from cvtdesign.io.variant import load_variant


def export_steps(console, variant_files, out_dir: Path):
    """The STEP assembly (+ SVG, PNG) of each variant file, for mechanical review (`--step`)."""
    files = list(dict.fromkeys(str(f) for f in variant_files if f))
    with progress_bar(console, "STEP export", lambda res: f"{Path(res['step']).name} ({len(res['parts'])} parts)") as progress:
        for k, f in enumerate(files):
            progress(k + 1, len(files), export_layout(f, out_dir))
    console.print(f"STEP assemblies of {len(files)} design(s) in {out_dir}")


def export_layout(variant_file, out_dir, gamma_deg: float = 45.0, check: bool = False) -> dict:
    """The variant file read here (io.variant; cad.export checks its geometry) and exported by
    cad.export.export_variant, its files named after the variant file."""
    layout = load_variant(variant_file, check=False)
    return export_variant(layout, out_dir, gamma_deg, check, stem=Path(variant_file).stem)


def run(args):
    res = export_layout(args.variant, args.out, args.gamma, args.check)
    console = Console(width=120)
    console.print(f"{res['step']}: {len(res['parts'])} parts at γ = {res['gamma_deg']:g}° (φ = {res['phi_deg']:.3f}°) "
                  f"in {res['seconds']:.1f} s; drawings {res['svg']}, {res['png']}")
    if not args.check:
        return 0
    t = Table(title=f"checks of the re-read STEP file ({res['check_seconds']:.1f} s)")
    for c in ("check", "result", "detail"):
        t.add_column(c)
    for row in res["checks"]:
        t.add_row(row["check"], "ok" if row["ok"] else "[red]FAILED[/red]", row["detail"])
    console.print(t)
    return 0 if all(row["ok"] for row in res["checks"]) else 1
