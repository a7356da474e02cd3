"""cvtdesign: design, optimise and compare spherical CVTs."""
