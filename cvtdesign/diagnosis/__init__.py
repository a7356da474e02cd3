"""Sim-to-real: the virtual rig, measured datasets, the diagnosis, its self-check on withheld effects, resteering, an independent simulator."""
