"""Track a spring whose stiffness jumps, online, with two estimators.

A 2 kg mass on a 400 N/m spring (damping 4 N·s/m) is shaken by a sinusoidal force; at t = 3 s the
spring stiffens to 900 N/m. We measure the position with white noise (50 dB) and estimate the
stiffness while the data arrive:

* the algebraic estimator (`StreamingAlgebraicEstimator`): each estimate uses only the last
  `window` seconds, fed in 50 ms chunks as a data-acquisition loop would deliver them;
* recursive least squares with forgetting factor λ < 1 (`RecursiveLeastSquares(...).stream()`),
  fed the same chunks of raw samples; it weighs old samples by λ^age and so forgets the old
  spring after about 1 / (1 − λ) samples.

The MSD's input is normalised, u = F/m [m/s²] (see docs/conventions.md), so the estimators
return θ2 = k/m; the stiffness is θ2 · m.

Run:  python examples/track_changing_stiffness.py   (PHYSID_EXAMPLE_QUICK=1 for a shorter run)
"""

from __future__ import annotations

import os

import numpy as np

from physid.estimators.algebraic import StreamingAlgebraicEstimator
from physid.estimators.recursive import RecursiveLeastSquares
from physid.simulate import simulate_msd

QUICK = os.environ.get("PHYSID_EXAMPLE_QUICK") == "1"
MASS = 2.0  # [kg]
K_BEFORE, K_AFTER, T_JUMP = 400.0, 900.0, 3.0  # [N/m], [N/m], [s]
DURATION = 5.0 if QUICK else 8.0  # [s]
DT = 1e-3  # [s]
CHUNK = 50  # samples per chunk delivered by the "acquisition loop"


def main() -> None:
    # Force 20 N at 1.5 times the initial natural frequency (ω0 = sqrt(400/2) = 14.1 rad/s).
    rec = simulate_msd(
        mass=MASS,
        stiffness=K_BEFORE,
        damping=4.0,
        force_amplitude=20.0,
        ratio=1.5,
        duration=DURATION,
        dt=DT,
        jumps=[(T_JUMP, K_AFTER)],
        snr_db=50.0,
        rng=7,
    )
    u, x, t = rec["u"], rec["x"], rec.t
    k_true = np.where(t < T_JUMP, K_BEFORE, K_AFTER)

    # Both estimators run online: the same chunks of raw (u, x) samples go to each, and each
    # keeps constant memory (the algebraic one its last window, RLS its pre-filter state and P).
    # 1) Algebraic estimator over a sliding 0.2 s window.
    algebraic = StreamingAlgebraicEstimator("msd", dt=DT, window=0.2, block=20)
    # 2) Recursive least squares with forgetting (λ = 0.998: memory of about 0.5 s at 1 kHz);
    #    stream() runs its state-variable pre-filter and the recursion chunk by chunk.
    rls = RecursiveLeastSquares("msd", forgetting=0.998).stream(dt=DT)
    k_alg = np.full(t.size, np.nan)
    k_rls = np.full(t.size, np.nan)
    for start in range(0, t.size, CHUNK):
        chunk = slice(start, start + CHUNK)
        upd = algebraic.update(u[chunk], x[chunk])
        theta2 = upd.estimates[:, upd.names.index("theta2")]
        k_alg[chunk] = np.where(upd.valid, theta2 * MASS, np.nan)
        upd_rls = rls.update(u[chunk], x[chunk])
        k_rls[chunk] = upd_rls.estimates[:, upd_rls.names.index("theta2")] * MASS

    print(f"stiffness jumps from {K_BEFORE:g} to {K_AFTER:g} N/m at t = {T_JUMP:g} s")
    print(f"{'t [s]':>6} {'true':>8} {'algebraic':>10} {'RLS':>8}   [N/m]")
    for when in np.arange(1.0, DURATION, 0.5):
        i = int(round(when / DT))
        # the median over the last 100 ms smooths the window-to-window scatter of the estimate
        recent = k_alg[max(i - 100, 0) : i + 1]
        k_a = np.nanmedian(recent) if np.isfinite(recent).any() else np.nan
        print(f"{t[i]:6.2f} {k_true[i]:8.1f} {k_a:10.1f} {k_rls[i]:8.1f}")

    # Recovery: first time after the jump from which the estimate stays within 2 % of 900 N/m.
    for name, k_est in (("algebraic", k_alg), ("RLS", k_rls)):
        after = t >= T_JUMP
        bad = after & ~(np.abs(k_est - K_AFTER) <= 0.02 * K_AFTER)
        last_bad = t[bad][-1] if bad.any() else T_JUMP
        settled = last_bad < t[-1] - 0.2
        text = f"{last_bad - T_JUMP:.2f} s" if settled else "not within the record"
        print(f"{name}: within 2 % of the new stiffness {text} after the jump")
    final = np.nanmedian(k_alg[-500:])
    print(
        f"final stiffness: algebraic {final:.1f} N/m, RLS {k_rls[-1]:.1f} N/m "
        f"(true {K_AFTER:g} N/m)"
    )


if __name__ == "__main__":
    main()
