"""Files: the variant schema and reader, units, the measured-data CSV, the one writer, plots, HTML reports, generated docs."""
