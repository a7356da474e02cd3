"""Contact mechanics of a roller on the sphere: Hertz's patch (hertz), Kalker's linear theory (core.contact.kalker), the
simplified theory FASTSIM (fastsim) and the creep-force surface built from it (surface), and the contact laws
that the model compiles: their interface (base) and the laws the package ships (laws)."""
