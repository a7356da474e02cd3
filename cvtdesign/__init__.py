"""cvtdesign: design, optimise, compare and diagnose spherical CVTs (docs/architecture.md).

Layers, each importing only from those below it: cli → design, cad, diagnosis → io → core → errors.
"""
