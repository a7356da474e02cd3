"""CAD for mechanical review: a layout as parts, a STEP assembly with its checks, drawings (CadQuery, imported lazily in kernel.py)."""
