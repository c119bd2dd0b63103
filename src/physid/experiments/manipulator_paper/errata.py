"""The errata of Cedro & Janecki found by the reproduction, each with its evidence."""

from __future__ import annotations

from ..data import Erratum
from ._common import PAPER, see


def errata(evidence) -> tuple[Erratum, ...]:
    """The paper's errata, each with the evidence physid measured for it.

    Long by design: a flat table of literal `Erratum` entries in the paper's order.

    Returns
    -------
    tuple of Erratum
    """
    n = 9.7 / 0.001
    return (
        Erratum(
            PAPER,
            "Section 2, kinetic energy K[k]",
            "K[k] = ½ m[k] Σ_i Σ_j ((Uk[j].r).(rᵀ.Uk[j]ᵀ))[[1]][[1]] q̇_j² — squared rates "
            "only, the [[1]][[1]] element summed over an index i that does not occur",
            "K[k] = ½ m[k] Σ_j Σ_l tr(Uk[j] r rᵀ Uk[l]ᵀ) q̇_j q̇_l (cross terms kept; the "
            "trace, i.e. [[i]][[i]] summed over i = 1..3)",
            f"Simulated exact and printed forms differ by up to {max(evidence['dq']):.3g} rad in "
            "q; the printed model fitted to exact-arm data gives m2 = "
            f"{evidence['mismatch_m2']:.3g} kg (truth 25)." + see("simulation"),
        ),
        Erratum(
            PAPER,
            "Section 2, potential energy V[k]",
            "V[k] = (−m[k] (0 0 g 0).T1…Tk.x)[[1]][[1]]",
            "…Tk.r — only r = (0, 0, 0, 1)ᵀ is defined; x is undefined",
            "The listing defines ob, r, T1..T4 and never x; with r the origin of frame k is "
            "used, consistent with the point masses at the link ends; the simulated responses "
            "use it." + see("simulation"),
        ),
        Erratum(
            PAPER,
            "Section 2, K0[k]",
            "rod inertia J[k] = m[k] l[k]²/12 with the joint's own rate, ½ J[k] φ̇_k², and the "
            "point mass m[k] at the end of link k",
            "a consistent model: a point mass has no rod inertia, a uniform rod has its centre "
            "at l/2 and rotates with the link's absolute angular velocity",
            "Mixing both makes m1 and l1 enter only as m1·l1² (T1 has no length); our models "
            "follow the paper to reproduce it." + see("identifiability"),
        ),
        Erratum(
            PAPER,
            "Section 3, eqs. (2)–(3)",
            "differential filter = low-pass correction filter H_k/H_∇k in series with a k-th "
            "order difference quotient",
            "Filtr1/Filtr2 integrate H1 = iΩ/Δ and H2 = (iΩ/Δ)² directly (ideal band-limited "
            "differentiators, Harris window); no difference quotient or eq. (3) appears in the "
            "code",
            "The printed Filtr1/Filtr2 listings; our filters follow the code, which is what the "
            "results depend on (the filter sweep uses them)." + see("filters"),
        ),
        Erratum(
            PAPER,
            "Section 3, Filtr/Filtr1/Filtr2 output",
            "xf = Table[0, {NN − 2M − 1}]; For[i = M+1, i ≤ NN − M − 1, …]",
            "NN − 2M valid outputs exist (i = M+1 … NN − M); the last one is dropped",
            "Count of the loop; physid's filters keep all NN − 2M (paper=True reproduces the "
            "paper's length); J is computed on them." + see("identification"),
        ),
        Erratum(
            PAPER,
            "Section 4, reference signal",
            "the step is 'filtered using a first-order low-pass filter with a boundary "
            "frequency Ω_g = 0.025'",
            "it is filtered with Filtr[100, 0.025, …], the 201-tap Harris-windowed FIR "
            "low-pass, and re-stamped from t = 0 (tp1), so it leads the raw steps by MΔ = 0.1 s",
            "The listing Mf[k] = Filtr[100, 0.025, 0.001, tp, Mp[k]]; tp1 = Δ Range[0, "
            "Length[Mf[1]] − 1]; Fig. 2 re-made with it." + see("simulation"),
        ),
        Erratum(
            PAPER,
            "Section 5, discrete quality factor Jd",
            "each joint's sum divided by Length[tp] − 2M",
            "Filtr returns Length[tp] − 2M − 1 samples; the mean needs that count (factor "
            f"{(evidence['n'] - 200 - 1) / (evidence['n'] - 200):.6f} on J)",
            "Length of the Filtr output (previous erratum)." + see("identification"),
        ),
        Erratum(
            PAPER,
            "Section 5, time grid tp",
            "tp = Table[Δ i, {i, 0, tk/Δ}] with tk = 9.7 (intended 9701 samples)",
            f"tk/Δ = {n!r} in binary floating point, so i stops at 9699: 9700 samples, the last "
            "(t = 9.7 s) missing",
            "IEEE 754: 9.7/0.001 = 9699.999999999998; Table uses Floor of the bound. physid "
            f"simulates all {evidence['n']} samples." + see("simulation"),
        ),
        Erratum(
            PAPER,
            "Section 5, Figs. 4–5 and text",
            "'parameter trajectories are determined after approximately 1450 iterations'",
            "~1450 evaluations of Jd (the counter j is incremented inside Jd); FindMinimum with "
            "two start values per variable is a derivative-free method",
            f"physid's least squares needs {evidence['nfev']} residual + {evidence['njev']} "
            f"Jacobian evaluations; Nelder–Mead on the same J needs {evidence['nm_nfev']}."
            + see("identification"),
        ),
        Erratum(
            PAPER,
            "Section 5, Jd listing",
            "Jd[…] := Module[{j, j = j + 1; …",
            "the counter j must be global (Module[{}, j = j + 1; …]); a local j would restart "
            "at 1 and overwrite the first history entry every time",
            "Syntax of Module: the first argument is the list of local variables; physid "
            "records every evaluation (Figs. 4–5 re-made)." + see("identification"),
        ),
        Erratum(
            PAPER,
            "Section 5, explanation of the final deviation",
            "'the negligible differences are attributable to the system non-linearity'",
            f"the m1·l1² deviation ({evidence['combo_err']:+.1f} %) comes from the in-band gain "
            "error of Filtr2 relative to s²·Filtr (up to "
            f"{evidence['filtr2_error']:.2g} over the motion's band); the other six parameters "
            f"are within {evidence['separate_err']:.2f} %",
            f"Same model, data and filter: m1·l1² {evidence['combo_err']:+.2f} % (paper "
            f"{evidence['paper_combo_err']:+.2f} %); with consistent derivative filters "
            f"{evidence['combo_err_consistent']:+.3f} %." + see("identification"),
        ),
        Erratum(
            PAPER,
            "Section 5, last paragraph before Fig. 3",
            "'the output error method involves comparing the object input signal φ with its "
            "estimate'",
            "φ is the object's output signal",
            "Fig. 1/section 4: φ is the response to the PD torques (Fig. 2 re-made)."
            + see("simulation"),
        ),
    )
