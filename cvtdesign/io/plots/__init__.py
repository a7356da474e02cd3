"""Matplotlib figures, drawn on Agg canvases without pyplot (no figure manager, no GUI backend), each written as a
PNG by output.write_file: one module per command's figures, the common parts in `base`, and the plotting
process in `process` (a command that draws while it computes hands it the figure function itself).

The names below are the package's interface: `from cvtdesign.io import plots; plots.compare_figure(...)`.
"""
from cvtdesign.io.plots.base import figure_parts, place_labels, points_along, save
from cvtdesign.io.plots.cad import cad_picture, scale_bar
from cvtdesign.io.plots.capacity import capacity_figure
from cvtdesign.io.plots.compare import (
    COMPARE_KEYS,
    EXISTING_COLOUR,
    IDEAL_COLOUR,
    PANELS_MAX,
    compare_figure,
    variant_colours,
)
from cvtdesign.io.plots.contact import contact_figures
from cvtdesign.io.plots.design import pareto_figure, tolerance_figure
from cvtdesign.io.plots.diagnosis import diagnosis_fit_figure, residual_map_figure, resteer_figure
from cvtdesign.io.plots.layout import beside_figure, layout_figure
from cvtdesign.io.plots.life import life_figure, temperature_figure
from cvtdesign.io.plots.optimum import convergence_figure, slack_figure
from cvtdesign.io.plots.transient import bode_figure, render_figure, step_figure
from cvtdesign.io.plots.process import Background, Forked, describe, worker

__all__ = ["Background", "COMPARE_KEYS", "Forked", "describe", "EXISTING_COLOUR", "IDEAL_COLOUR", "PANELS_MAX", "cad_picture",
           "beside_figure", "bode_figure", "capacity_figure", "compare_figure", "contact_figures", "convergence_figure",
           "diagnosis_fit_figure", "figure_parts", "layout_figure", "life_figure", "pareto_figure", "render_figure", "slack_figure", "place_labels", "points_along", "residual_map_figure", "resteer_figure", "save", "scale_bar", "step_figure",
           "temperature_figure", "tolerance_figure", "variant_colours", "worker"]
