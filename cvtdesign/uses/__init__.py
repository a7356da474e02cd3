"""The uses of the model as functions that return Python objects: compare, capacity, life, diagnose, and the
evaluation at one's own points. The commands (cli) and the Python API (cvtdesign.api, which re-exports the
public names) both call them. This package's own __init__ imports nothing, so that a command loads only the
module it needs (a plain `compare` loads neither pandas nor the diagnosis)."""
