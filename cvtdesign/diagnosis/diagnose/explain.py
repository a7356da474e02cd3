"""What the candidates leave open: pairs of candidates the data cannot tell apart (and where to measure to
separate them), and where a remaining gap lies beyond the vocabulary (model-form checks)."""
from __future__ import annotations

import numpy as np

from cvtdesign.diagnosis.diagnose.crossval import Score
from cvtdesign.diagnosis.diagnose.fitting import Fit
from cvtdesign.diagnosis.diagnose.predictor import CHANNELS, Models, residuals, zscores
from cvtdesign.diagnosis.diagnose.search import Candidate, signature
from cvtdesign.diagnosis.diagnose.significance import f_oneway
from cvtdesign.diagnosis.measured import Measured

FORM_BINS = 8          # quantile bins of a variable in the model-form checks (one-way ANOVA of the residual)
FORM_WORDS = {"gamma_cmd_deg": "the commanded γ", "tau_perp_Nm": "the load τ⊥", "omega_1_rad_s": "the motor speed ω1",
              "drive_spin_ratio_1_m": "the drive rollers' spin ratio |Ω·n|/V", "rolling_speed_m_s": "the rolling speed",
              "min_normal_force_N": "the smallest normal force", "max_utilisation": "the largest traction "
              "utilisation F/(μN)"}   # the model-form checks' variables in words


def confounded(first_rows: list[Candidate], base: Score, noise, data, models: Models, cos_limit=0.9):
    """Pairs of candidates whose fitted signatures (changes of the predictions, z units, measured channels)
    are nearly parallel (cosine ≥ cos_limit) and both above noise, with their held-out scores, where they
    differ most and which measurement would tell them apart (`suggest_points`)."""
    out = []
    sig = {r.effect: signature(base, r.score, noise) for r in first_rows}
    meas = np.array([c in noise for c in CHANNELS])
    for i, a in enumerate(first_rows):
        for b in first_rows[i + 1:]:
            sa, sb = sig[a.effect], sig[b.effect]
            va, vb = sa[meas].ravel(), sb[meas].ravel()
            na, nb = np.linalg.norm(va), np.linalg.norm(vb)
            if na < 3 or nb < 3:        # a signature within noise is not a rival
                continue
            cos = float(va @ vb / (na * nb))
            if cos < cos_limit:
                continue
            diff = np.abs(sa - sb)            # (channel, point)
            by_channel = {c: float(np.sqrt(np.mean(diff[k] ** 2))) for k, c in enumerate(CHANNELS)}
            points = suggest_points(models, data, noise, a.score.fit, b.score.fit)
            axis = not data.has_axis and by_channel["axis"] > 2 * max(by_channel["alpha"], by_channel["tau_par"])
            hint = ("measure the axis angle (gamma_axis_deg), or " if axis else "") + "measure at " + "; ".join(
                f"γ = {p['gamma_deg']:.0f}°, τ⊥ = {p['load_Nm']:+.2f} N·m" for p in points[:3])
            out.append({"effects": [a.effect, b.effect], "cosine": cos, "separation_z_rms": by_channel,
                        "heldout_msz": [a.cmp.msz[1], b.cmp.msz[1]], "suggested_points": points,
                        "separate_by": hint})
    return out


def suggest_points(models: Models, data: Measured, noise: dict, fa: Fit, fb: Fit, n: int = 5) -> list[dict]:
    """The operating points that best separate two fitted models: over the variant's whole envelope (its γ
    range at 5° steps, its loads, the data's mean motor speed), the points where their predictions of the
    measured channels differ most, in units of each channel's typical noise per row; `n` of them, at least
    15° apart in γ."""
    L = models.layout
    g = np.radians(np.arange(np.degrees(L.gamma_grid.min()), np.degrees(L.gamma_grid.max()) + 1e-9, 5.0))
    G, T = np.meshgrid(g, L.load_grid, indexing="ij")
    w = float(np.mean(data.rows["omega_1"]))
    sigma = {c: float(np.median(v * np.sqrt(data.rows["count"].to_numpy()))) for c, v in noise.items()}
    preds = []
    for f in (fa, fb):
        P = models.get(f.effects)
        r = P.evaluate(G, T, w, f.theta)
        preds.append({"alpha": np.degrees(r["alpha"]), "axis": np.degrees(r["gamma_axis"]),
                      "tau_par": P.model.frame.load_split(G, r["tau_1"], r["tau_2"])[1]})
    sep = np.sqrt(sum(((preds[0][c] - preds[1][c]) / sigma[c]) ** 2 for c in sigma))
    sep = np.where(np.isfinite(sep), sep, -1.0)
    out = []
    for i in np.argsort(-sep.max(axis=1)):          # best γ first, at least 15° from those already chosen
        j = int(np.argmax(sep[i]))
        g_i = float(np.degrees(G[i, j]))
        if sep[i, j] > 0 and all(abs(g_i - p["gamma_deg"]) >= 15 - 1e-9 for p in out):
            out.append({"gamma_deg": g_i, "load_Nm": float(T[i, j]), "separation_z": float(sep[i, j])})
        if len(out) == n:
            break
    return out


def form_checks(models: Models, data: Measured, final: Score, noise: dict) -> dict:
    """Where a remaining gap lies beyond the vocabulary: the final model's full-fit residuals (z units) tested
    for structure along each input (commanded γ, the load level τ⊥, the motor-speed level ω1: levels, not the
    measured values, whose noise is already in the residual) and along the model's own derived quantities at
    each point (the drive rollers' spin ratio |Ω·n|/V [1/m], their rolling speed V [m/s], the smallest normal
    force [N] and the largest traction utilisation). Per variable and channel, the points are put in FORM_BINS
    quantile bins and the bin means compared by a one-way ANOVA F-test (scale-free, so a misestimated noise
    level does not matter), and the size of the dependence: the RMS of the bins' mean residual beyond what
    noise gives, in units of one reading's noise (z of a point's mean × √count). Returns each variable's
    smallest p-value over the channels and its size, and the variable along which the gap lies: the smallest
    p, if it is below 0.001 after Bonferroni over every test (`lies_along`; its size decides, verdict.py)."""
    r = data.rows
    ok = final.ok
    z = zscores(residuals(data, final.fit.pred), noise)[:, ok]
    P = models.get(final.effects)
    m = P.model
    ev = P.evaluate(np.radians(r["gamma_cmd_deg"].to_numpy()[ok]), r["tau_perp"].to_numpy()[ok],
                    r["omega_1"].to_numpy()[ok], final.fit.theta)
    drive = np.array([x.role != "steering" for x in m.layout.rollers])
    r2 = float(next(x.radius for x in m.layout.rollers if x.role == "drive" and x.shaft == 2))
    variables = {"gamma_cmd_deg": r["gamma_cmd_deg"].to_numpy()[ok],
                 "tau_perp_Nm": data.load_levels[r["load_bin"].to_numpy()[ok]],
                 "omega_1_rad_s": data.speed_levels[r["speed_bin"].to_numpy()[ok]],
                 "drive_spin_ratio_1_m": np.nanmean(np.abs(ev["spin"][drive]), axis=0),
                 "rolling_speed_m_s": np.abs(ev["omega_2"]) * r2, "min_normal_force_N": np.nanmin(ev["N"], axis=0),
                 "max_utilisation": np.nanmax(ev["utilisation"], axis=0)}
    reading = np.sqrt(np.mean(r["count"].to_numpy()[ok]))
    p, size = {}, {}
    for name, v in variables.items():
        bins = _quantile_bins(v)
        good = np.isfinite(v) & np.all(np.isfinite(z), axis=0)
        p[name], size[name] = 1.0, 0.0
        if bins is None:
            continue
        groups = [[zc[good & (bins == k)] for k in np.unique(bins[good])] for zc in z]
        if len(groups[0]) > 1:
            p[name] = min(f_oneway(*g)[1] for g in groups)
            size[name] = max(_between_bins(g) for g in groups) / reading
    top = min(p, key=p.get)
    along = top if p[top] < 1e-3 / (len(p) * len(z)) else None
    return {"p": p, "size": size, "lies_along": along}


def _between_bins(groups: list) -> float:
    """RMS over the points of their bin's mean z beyond the noise's share (1/n per bin): √(Σ n m² − B)/N."""
    n = np.array([len(g) for g in groups])
    m = np.array([np.mean(g) for g in groups])
    return float(np.sqrt(max(np.sum(n * m ** 2) - len(groups), 0.0) / n.sum()))


def _quantile_bins(v: np.ndarray):
    """Bin index of each value in FORM_BINS quantile bins; None when v does not vary (or is too short)."""
    fin = np.isfinite(v)
    if fin.sum() < 2 * FORM_BINS or np.ptp(v[fin]) <= 1e-12 * max(1.0, np.max(np.abs(v[fin]))):
        return None
    edges = np.unique(np.quantile(v[fin], np.linspace(0, 1, FORM_BINS + 1)))
    return np.clip(np.searchsorted(edges, v, side="right") - 1, 0, len(edges) - 2)
