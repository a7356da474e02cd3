"""The sim-to-real gap: where it lies, which unmodelled effect causes it, how far it shrinks.

The steps, each in a module of its own (docs/diagnosis.md):
 1. predictor: the model with a set of effects (the effect vocabulary) evaluated at the dataset's operating
    points; residuals = measured − predicted.
 2. spatial: the operating points' neighbours in their own space (γ, τ⊥[, ω1]), whatever the protocol.
 3. sequence and outliers: the direction each γ was approached from (hysteresis), and gross outliers left
    out and named.
 4. noise: the noise level of each channel at each point (replicates, else local fits over neighbours);
    residuals divided by it are z-scores, which weight the fit.
 5. fitting: the effect parameters by bounded Gauss-Newton with the model's exact Jacobian, with ±1σ.
 6. crossval and search: each candidate effect added in turn, refitted and scored held out; the one that
    removes most of the gap accepted when it is also significant, and the search repeated.
 7. verdict: named, `none` or `unexplained`, from the size of the gap left in physical units.
 8. explain: pairs the data cannot tell apart, and where a remaining gap lies beyond the vocabulary;
    sequence: the drift over the test.
 9. report: the findings (Report), JSON-ready, with the evidence the figures are drawn from.
`run.diagnose` runs them in that order.
"""
from cvtdesign.diagnosis.diagnose.crossval import compare, folds, score
from cvtdesign.diagnosis.diagnose.fitting import fit
from cvtdesign.diagnosis.diagnose.noise import estimate_noise
from cvtdesign.diagnosis.diagnose.predictor import Predictor, model_efficiency, residuals
from cvtdesign.diagnosis.diagnose.report import Report
from cvtdesign.diagnosis.diagnose.run import diagnose, fit_model
from cvtdesign.diagnosis.diagnose.spatial import neighbours
from cvtdesign.diagnosis.diagnose.verdict import SHRINK_MIN

__all__ = ["Predictor", "Report", "SHRINK_MIN", "compare", "diagnose", "estimate_noise", "fit", "fit_model", "folds",
           "model_efficiency", "neighbours", "residuals", "score"]
