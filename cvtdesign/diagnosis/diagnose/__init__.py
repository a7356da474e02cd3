"""The sim-to-real gap: where it lies, which unmodelled effect causes it, how far it shrinks.

The steps, each in a module of its own:
 1. predictor: the model with a set of effects (the effect vocabulary) evaluated at the dataset's operating
    points; residuals = measured − predicted.
 2. noise: the noise level of each channel at each point (replicates, else second differences along the
    load); residuals divided by it are z-scores, which weight the fit.
 3. fitting: the effect parameters by bounded Gauss-Newton with the model's exact Jacobian, with ±1σ.
 4. spatial: where the gap lies (regions of the γ × load grid) and whether it is structured.
 5. crossval and search: each candidate effect added in turn, refitted and scored held out; the best
    significant one accepted, and the search repeated; the verdict.
 6. explain: pairs the data cannot tell apart, and where a remaining gap lies beyond the vocabulary.
 7. report: the findings (Report), JSON-ready, with the evidence the figures are drawn from.
`run.diagnose` runs them in that order.
"""
from cvtdesign.diagnosis.diagnose.crossval import compare, folds, score
from cvtdesign.diagnosis.diagnose.fitting import fit
from cvtdesign.diagnosis.diagnose.noise import estimate_noise
from cvtdesign.diagnosis.diagnose.predictor import Predictor, model_efficiency, residuals
from cvtdesign.diagnosis.diagnose.report import Report
from cvtdesign.diagnosis.diagnose.run import diagnose, fit_model
from cvtdesign.diagnosis.diagnose.search import SHRINK_MIN
from cvtdesign.diagnosis.diagnose.spatial import point_grid

__all__ = ["Predictor", "Report", "SHRINK_MIN", "compare", "diagnose", "estimate_noise", "fit", "fit_model", "folds",
           "model_efficiency", "point_grid", "residuals", "score"]
