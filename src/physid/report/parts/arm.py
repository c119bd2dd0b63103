"""Part III of the report: a 6-DOF arm identified end to end, rendered.

Each function turns one `physid.experiments.data.SectionData` of `physid.experiments.arm6` into
a `ReportSection`. Where a piece the section needs is missing from this build, the section says
so in plain words and shows no number.
"""

from __future__ import annotations

from html import escape

from ..html import FigureSpec, Html, ReportSection
from ..robot import plot_bias_bars, plot_excitation, plot_torque_prediction
from ._common import make_section

PART = "Part III — a 6-DOF arm identified end to end, from its URDF"


_section = make_section(PART)


def _missing(r) -> list[str]:
    if not r.get("missing"):
        return ["Not run: an earlier step of this part did not complete (see above)."]
    why = "; ".join(r.get("missing_reasons", []))
    return [
        "Not run in this build of physid. This section needs "
        + ", ".join(r["missing"])
        + ", which are not all in yet, and shows no number until they are."
        + (f" Details: {why}." if why else "")
    ]


def overview(sd, r) -> ReportSection:
    paragraphs = [
        "This part does what a robotics engineer does with a new arm, in physid alone: load its "
        "URDF (physid.load_model, with friction and armature from a sidecar file), design an "
        "excitation trajectory within the joint limits, run it in closed loop with encoder and "
        "torque noise, identify the base parameters with the inverse dynamic model (IDIM) by "
        "least squares and by instrumental variables, and with the input-error method of Part "
        "I over the same base parameters, make the estimate physically consistent, and "
        "validate it on a trajectory the fit has not seen.",
    ]
    if "iv_bias" in r:
        paragraphs.append(
            f"Measured: over {r['n_seeds']} noisy records of the {r['n_joints']}-joint arm, the "
            f"{r['n_base']} base parameters carry a bias from the noise of "
            f"{100 * r['iv_bias']:.2g} % with IDIM-IV against {100 * r['ols_bias']:.2g} % with "
            "IDIM-OLS"
            + (
                f" and {100 * r['ie_bias']:.2g} % with input-error (its noise compensation)"
                if "ie_bias" in r
                else ""
            )
            + " (well-excited parameters"
            + ("; this few seeds do not separate bias from scatter" if r["n_seeds"] < 5 else "")
            + f"), on top of a {100 * r['noise_free_error']:.2g} % error that the noise-free fit "
            "already has"
            + (
                f"; the held-out torque is predicted within {100 * r['held_out_error_iv']:.2g} %."
                if "held_out_error_iv" in r
                else "."
            )
        )
    else:
        paragraphs.extend(_missing(r))
    return _section(sd, paragraphs)


def excitation(sd, r) -> ReportSection:
    if not r.get("available"):
        return _section(sd, _missing(r))
    paragraphs = [
        f"A finite Fourier series of {r['harmonics']} harmonics per joint with a period of "
        f"{r['period_s']:g} s (Swevers et al.), within the joint limits of the URDF. What "
        "matters for identification is the condition number of the base regressor along the "
        "trajectory (columns scaled to unit norm): the lower it is, the less the noise is "
        "amplified into the estimates.",
    ]
    if "designed_condition_number" in r:
        paragraphs.append(
            f"The designed trajectory reaches {r['designed_condition_number']:.3g}, against a "
            f"median of {r['random_median']:.3g} over {r['n_random']} random trajectories with "
            f"the same limits: {r['improvement']:.2g} times lower."
        )
    else:
        reason = r.get("design_error") or "the excitation design is not in this build"
        paragraphs.append(
            f"No designed trajectory ({reason}): the best of the {r['n_random']} random "
            f"trajectories stands in (condition number {r['stand_in_condition_number']:.3g}; "
            f"median {r['random_median']:.3g})."
        )
    d = sd.figure("arm6_excitation").data
    figures = [
        FigureSpec(
            "arm6_excitation",
            plot_excitation(
                d["t"],
                d["q"],
                d["limits"],
                d["random"],
                d["designed_cond"],
                used=None if d["designed"] else r["stand_in_seed"] - 1,
                title="The excitation trajectory of each joint, and its condition number",
            ),
            "The trajectory used stays between the position limits (dashed); the bars compare "
            "its condition number with those of random trajectories.",
            alt="Six small panels of joint angle against time over one period, each a smooth "
            "periodic curve between dashed position limits, and below them a bar chart of "
            "condition numbers on a log scale for the trajectory used and for random "
            "trajectories, with their median dotted.",
        )
    ]
    return _section(sd, paragraphs, figures)


def identification(sd, r) -> ReportSection:
    if not r.get("available"):
        if r.get("error"):
            return _section(sd, [Html(f"The fits failed: <code>{escape(r['error'])}</code>.")])
        return _section(sd, _missing(r))
    m = r["methods"]
    ols = r["idim-ols_first_seed"]
    iv = r["idim-iv_first_seed"]
    ratio = r["iv_over_ols_noise_bias"]
    paragraphs = [
        f"Each of {len(r['seeds'])} records is the closed loop (PD control) on the excitation "
        f"with encoder noise of {r['encoder_std_rad']:g} rad and torque noise of "
        f"{100 * r['torque_noise_fraction']:g} % of each joint's rms torque. IDIM-OLS filters q "
        "to get q̇ and q̈, evaluates the base regressor on them, low-passes and decimates every "
        f"column (here by {ols['decimate']}) and solves least squares: the noise in q then sits "
        "in the regressor, and the estimates are biased (errors in variables). IDIM-IV replaces "
        "the noisy regressor by one evaluated on a simulated closed loop of the current "
        f"estimate; it took {iv['iterations']} iterations on the first record.",
        f"Over the {r['n_well_excited']} well-excited base parameters (relative spread below "
        f"{100 * r['well_excited_spread']:g} %), the mean error over the seeds, relative to the "
        f"truth, is {100 * r['mean_abs_relative_bias']['idim-ols']:.2g} % for IDIM-OLS and "
        f"{100 * r['mean_abs_relative_bias']['idim-iv']:.2g} % for IDIM-IV. "
        + (
            "Most of it"
            if r["mean_abs_noise_free_error"] > 0.5 * r["mean_abs_relative_bias"]["idim-ols"]
            else "Part of it"
        )
        + " is there without noise: the same trajectory without noise already gives "
        f"{100 * r['mean_abs_noise_free_error']:.2g} % (the state filter and the parallel filter "
        "smear each stick/slip switch of the exact Coulomb friction, and some directions are "
        "weakly excited). The bias the "
        "noise adds (noisy mean minus the noise-free fit, the errors-in-variables part that IV "
        f"is for) is {100 * r['mean_abs_noise_bias']['idim-ols']:.2g} % for OLS and "
        f"{100 * r['mean_abs_noise_bias']['idim-iv']:.2g} % for IV"
        + (f" (IV/OLS ratio {ratio:.2g})." if ratio is not None else ".")
        + " The nominal 95 % intervals contain the truth in "
        + " and ".join(
            f"{100 * m[k]['coverage']:.0f} % of the cases for {k.upper()}"
            for k in ("idim-ols", "idim-iv")
            if m[k]["coverage"] is not None
        )
        + (
            f" (only {len(r['seeds'])} seeds in this quick run: rough)."
            if len(r["seeds"]) < 5
            else "."
        ),
        (
            f"{len(r['failures'])} of the {len(r['seeds'])} records could not be fitted and are "
            "left out (the first error is quoted below). "
            if r.get("failures")
            else ""
        )
        + f"The base regressor's condition number on the first record is "
        f"{ols['condition_number']:.3g}.",
        _input_error_paragraph(r),
    ]
    if r.get("failures"):
        paragraphs.append(
            Html(f"First fit error: <code>{escape(r['failures'][0]['error'])}</code>.")
        )
    d = sd.figure("arm6_bias_bars").data
    figures = [
        FigureSpec(
            "arm6_bias_bars",
            plot_bias_bars(
                d["well"] or d["names"],
                {_LABELS.get(k, k): v for k, v in d["bias"].items()},
                title="Bias the noise adds to each well-excited base parameter, per method",
            ),
            _bias_caption(r),
            alt="Grouped bars on a log scale, one pair per well-excited base parameter: the "
            "absolute bias the noise adds (noisy mean minus the noise-free fit, relative to the "
            "truth) for IDIM-OLS, IDIM-IV and input-error in percent (each against its own "
            "noise-free fit). Parameters that the "
            "trajectory does not excite well are left out (their relative errors are "
            "meaningless); the table lists all of them.",
        )
    ]
    return _section(sd, paragraphs, figures)


_LABELS = {"idim-ols": "IDIM-OLS", "idim-iv": "IDIM-IV", "input-error": "input-error"}


def _input_error_paragraph(r) -> str:
    """Input-error beside IDIM: what it does on the robot and its numbers (all from results)."""
    m = r["methods"]
    if "input-error" not in m:
        return "The input-error method did not run on this arm."
    ie, first = m["input-error"], r["input-error_first_seed"]
    noise = (
        "compensates the errors-in-variables bias of the encoder noise with re-noised "
        "replicates of the record (noise='auto' found q noisy)"
        if first["noise"] == "compensate"
        else "found no noise to compensate"
    )
    cov = [
        f"{100 * m[k]['coverage_well_excited']:.0f} % for {_LABELS[k]}"
        for k in ("idim-ols", "idim-iv", "input-error")
        if m[k]["coverage_well_excited"] is not None
    ]
    return (
        "Input-error, the method of Part I, applied to the robot with physid's defaults: on a "
        "rigid-body model it estimates the base parameters themselves (the torque is linear "
        "in them, so the Jacobian of its residual is the base regressor and one least-squares "
        "step is the minimum), on q and τ through its FIR filters without decimation (on the "
        f"first record M = {first['half_width']} and Ω_g = {first['cutoff']:.3g} rad/sample, "
        f"chosen from the spectrum of q: {first['n_rows']} samples against {ols_rows(r)} for "
        f"IDIM after decimation), and it {noise}. Over the well-excited parameters its mean |error| is "
        f"{100 * ie['mean_abs_error']:.2g} % (IDIM-OLS {100 * m['idim-ols']['mean_abs_error']:.2g}"
        f" %, IDIM-IV {100 * m['idim-iv']['mean_abs_error']:.2g} %), the bias the noise adds "
        f"{100 * r['mean_abs_noise_bias']['input-error']:.2g} % against its own noise-free fit, "
        "and the nominal 95 % intervals contain the truth in "
        + ", ".join(cov)
        + "."
        + _input_error_coverage_note(r)
        + f" A fit takes {ie['wall_time_per_fit_s']:.2g} s, against "
        f"{m['idim-ols']['wall_time_per_fit_s']:.2g} s for IDIM-OLS and "
        f"{m['idim-iv']['wall_time_per_fit_s']:.2g} s for IDIM-IV."
    )


def _input_error_coverage_note(r) -> str:
    """Why input-error's intervals miss, when they do (decided by the numbers)."""
    ie = r["methods"]["input-error"]
    cov = ie["coverage_well_excited"]
    if cov is None or cov >= 0.9 or r["input-error_first_seed"]["noise"] != "compensate":
        return ""
    return (
        " Its intervals are too narrow here: compensated, they carry the scatter the noise "
        "causes (mean standard error "
        f"{100 * ie['mean_relative_stderr_well_excited']:.2g} % of the truth), not the error "
        "its fit has without noise ("
        f"{100 * r['input_error']['mean_abs_noise_free_error']:.2g} %: the regressor is "
        "evaluated on filtered signals, and filtering does not commute with its nonlinear "
        "terms (velocity products, Coulomb friction's sign(q̇)); IDIM filters the regressor's columns "
        "instead, and its residual-based intervals absorb what remains)."
    )


def ols_rows(r) -> int:
    """Rows of the first IDIM-OLS regression (decimated)."""
    return int(r["idim-ols_first_seed"]["n_rows"])


def _bias_caption(r) -> str:
    """What the bias bars show, decided by the numbers (never a fixed claim)."""
    ols = r["mean_abs_noise_bias"]["idim-ols"]
    iv = r["mean_abs_noise_bias"]["idim-iv"]
    few = len(r["seeds"]) < 5
    if iv <= 0.5 * ols:
        text = "IV removes most of the least-squares bias on the well-excited parameters"
    elif iv < ols:
        text = "IV lowers the least-squares bias on the well-excited parameters, but not by much"
    else:
        text = "here IV does not lower the least-squares bias"
    return text + ("; with this few seeds bias and scatter are not separated." if few else ".")


def consistency(sd, r) -> ReportSection:
    if not r.get("available"):
        paragraphs = _missing(r)
        if r.get("skipped_in_quick_run"):
            paragraphs = [
                "The physically consistent estimate (every link's pseudo-inertia positive "
                "definite, friction non-negative) runs in the full demo (physid demo), not in "
                "this quick one: the constrained fit takes minutes on a loaded machine."
            ]
        elif r.get("error"):
            paragraphs = [
                Html(f"The consistent estimate failed: <code>{escape(r['error'])}</code>.")
            ]
        return _section(sd, paragraphs)
    at = r["at_boundary"]
    paragraphs = [
        "Least squares can return base parameters that no real arm has (a negative mass, an "
        "inertia that violates the triangle inequality). The consistent estimate constrains "
        "every link's 4×4 pseudo-inertia to be positive definite and the friction coefficients "
        f"to be non-negative. Its cost is {r['cost_ratio']:.4g} times that of the unconstrained "
        "fit"
        + (
            f"; {r['n_at_boundary']} term(s) end at the boundary: {', '.join(at)}."
            if at
            else "; no link ends at the boundary."
        ),
    ]
    return _section(sd, paragraphs)


def validation(sd, r) -> ReportSection:
    if not r.get("available"):
        if r.get("error"):
            return _section(
                sd, [Html(f"The validation failed: <code>{escape(r['error'])}</code>.")]
            )
        return _section(sd, _missing(r))
    m = r["methods"]
    paragraphs = [
        "A different trajectory (another random Fourier series), simulated in closed loop with "
        "noise, predicted by each fit from its measured motion: the relative torque error "
        f"‖τ̂ − τ‖/‖τ‖ over all joints is {100 * m['idim-ols']['relative_error']['overall']:.2g} % "
        f"for IDIM-OLS and {100 * m['idim-iv']['relative_error']['overall']:.2g} % for IDIM-IV, "
        "computed on the filtered, decimated signals the fit used (the robotics convention).",
        f"The worst joint is {r['worst_joint']} ({100 * r['worst_joint_error']:.2g} % error). "
        f"Residual whiteness: the table gives, per joint, the share of the first {r['lags']} "
        f"autocorrelation lags of the IV residual outside the {r['band_percent']} % band; a white "
        f"residual has almost none outside. Here {r['n_not_white']} of the {r['n_joints']} "
        f"joints have more than {100 * r['white_threshold']:g} % of their lags outside"
        + (
            ": the residual is not white, so part of the torque is left unexplained (unmodelled "
            "dynamics, or filtering that leaves correlated errors), and the standard errors "
            "should be read with care."
            if r["n_not_white"]
            else ": the residual is white."
        ),
        Html(
            "The same check on your own recordings is <code>physid validate FIT.json "
            "held-out.csv --model MODEL</code>."
        ),
    ]
    d = sd.figure("arm6_validation_torques").data
    figures = [
        FigureSpec(
            "arm6_validation_torques",
            plot_torque_prediction(
                d["t"],
                d["measured"],
                d["predicted"],
                title="Held-out trajectory: measured and IDIM-IV-predicted torque per joint",
            ),
            "The predicted torque follows the measured one on every joint of a trajectory the "
            "fit has not seen.",
            alt="Six small panels, one per joint, of the filtered measured torque and the "
            "torque predicted by IDIM-IV against time; the two curves nearly coincide.",
        )
    ]
    return _section(sd, paragraphs, figures)


RENDERERS = {
    "arm6.overview": overview,
    "arm6.excitation": excitation,
    "arm6.identification": identification,
    "arm6.consistency": consistency,
    "arm6.validation": validation,
}
