"""Proof of the model and of its diagnosis, kept apart from both: the self-check of the diagnosis on data with
effects withheld (selfcheck.py), and an independently written simulator of Kim's existing CVT that makes such
data in forms that are not the package's own (independent_sim.py: its equations and solve; newton.py: its
solver; independent_rig.py: its rig and the self-check's cases on it)."""
