"""cvtdesign: design, optimise, compare and diagnose spherical CVTs (docs/architecture.md).

Layers, each importing only from those below it: cli, api → uses → design, cad, diagnosis → io → core → errors.
From Python: `from cvtdesign import api` (docs/python-api.md).
"""
