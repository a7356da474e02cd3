"""Contact mechanics of a roller on the sphere: Hertz's patch (hertz), Kalker's linear theory (kalker), the
simplified theory FASTSIM (fastsim) and the creep-force surface built from it (surface), and the contact laws
that the model compiles (laws): `kim` (Kim et al.'s fitted creep constants) and `kalker`."""
