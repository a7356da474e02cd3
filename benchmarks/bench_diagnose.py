"""Speed of the diagnosis, printed as figures and as ratios to baselines run in the same process.

1. `diagnose` of a 187-row dataset (Kim's protocol on variants/existing.yaml, steering lateral creep withheld
   from a drive-creep-only base) against every candidate of the effect vocabulary: the whole diagnosis (noise,
   base fit, 7 candidates × (full fit + 5 cross-validation fits), the greedy second round) — target < 60 s —
   against one evaluation of the base model at the 187 rows, the unit of work.
2. One weighted fit of the base model with the model's exact Jacobian (CasADi through the Newton solves)
   against the same fit with scipy's finite-difference Jacobian, from the same start to the same optimum.
3. Scale: the same diagnosis on Kim's protocol × 27 replicates (5049 rows) and × 535 (≈ 100k rows), reading
   the CSV included, as ratios to the 187-row diagnosis (target ≤ 3× for 5049 rows): replicates are merged
   into operating points, so the fit's cost follows the 187 points, not the rows.

Run: python benchmarks/bench_diagnose.py   (the machine is shared and noisy: best of repeats)
"""
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from cvtdesign.diagnosis import diagnose
from cvtdesign.diagnosis import measured
from cvtdesign.diagnosis import rig
from cvtdesign.io.variant import load_variant
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]
KIM = ("drive_longitudinal_creep", "steering_lateral_creep")



def main():
    L = load_variant(ROOT / "variants/existing.yaml")
    rows, _ = rig.simulate(L, KIM, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "d.csv"
        path.write_text(rig.to_csv_text(rows))
        data = measured.load_measured(path, L)
    base = ("drive_longitudinal_creep",)
    t_diag, rep = best_of(lambda: diagnose.diagnose(L, data, base), 1)
    P = diagnose.Predictor(L, base, data)
    t_eval, _ = best_of(lambda: P(P.defaults), 20)
    print(f"1. diagnose, {len(data.rows)} rows, {len(rep['candidates'])} candidates: {t_diag:.1f} s (target < 60 s), "
          f"verdict {rep['verdict']}; one base-model evaluation at the rows {1e3 * t_eval:.1f} ms; "
          f"ratio {t_diag / t_eval:.0f} evaluations' worth")

    # 2. exact Jacobian vs finite differences, same weighted problem
    data = measured.merge_points(data)
    P2 = diagnose.Predictor(L, KIM, data)
    noise = diagnose.estimate_noise(P2, data)
    t_exact, f_exact = best_of(lambda: diagnose.fit(P2, data, noise, multistart=False), 3)

    def z(theta):
        pred, ok = P2(theta)
        res = diagnose.residuals(data, pred)
        return np.concatenate([res[c] / noise[c] for c in res])

    lo, hi = diagnose._bounds(P2.names)
    t_fd, sol = best_of(lambda: least_squares(z, P2.defaults, jac="2-point", bounds=(lo, hi), method="trf",
                                              x_scale=np.abs(P2.defaults), xtol=1e-10, ftol=1e-10), 3)
    agree = np.max(np.abs(sol.x - f_exact.theta) / np.abs(f_exact.theta))
    print(f"2. base fit ({len(P2.names)} parameters): exact Jacobian {1e3 * t_exact:.0f} ms vs finite differences "
          f"{1e3 * t_fd:.0f} ms (ratio {t_fd / t_exact:.2f}); parameters agree to {agree:.1e} relative")

    # 3. scale: replicated datasets, from the CSV on disk
    t_small = _from_csv(L, rig.kim_protocol(L), base)
    for reps in (27, 535):
        t = _from_csv(L, rig.kim_protocol(L, replicates=reps), base)
        print(f"3. diagnose from the CSV, {187 * reps} rows ({reps} replicates): {t:.1f} s, "
              f"ratio {t / t_small:.2f} to 187 rows ({t_small:.1f} s)" + ("  (target ≤ 3)" if reps == 27 else ""))


def _from_csv(L, protocol, base) -> float:
    rows, _ = rig.simulate(L, KIM, protocol=protocol, seed=3)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "d.csv"
        path.write_text(rig.to_csv_text(rows))
        t = time.perf_counter()
        diagnose.diagnose(L, measured.load_measured(path, L), base)
        return time.perf_counter() - t


if __name__ == "__main__":
    main()
