"""`physid demo`: the papers reproduced, a 6-DOF arm identified, one self-contained report.

`run_demo` runs the experiments (`physid.experiments.manipulator_paper`,
`physid.experiments.msd_paper`, `physid.experiments.arm6`), each of which returns a list of
`physid.experiments.data.SectionData`; `physid.report.parts` renders each section from its data
(paragraphs from the results as read back from JSON, figures in the one style of
`physid.report.style`). The demo adds its own sections: what physid does in one screen (the
headline result of each part beside the paper's number), the part errata lists, what to run on
your own data, the errata summary, and the versions and run times. The result is written by
`physid.report.html.write_report` into a staging folder beside ``out_dir`` and moved in at the
end, so an interrupted demo never leaves a partial or mixed folder.

Example
-------
>>> import tempfile
>>> from physid.report.html import ReportSection
>>> def tiny(quick=False, progress=None):
...     return [ReportSection("Tiny experiment", results={"answer": 42})]
>>> paths = run_demo(tempfile.mkdtemp() + "/out", quick=True, experiments=[tiny])
>>> paths.html.name
'report.html'
"""

from __future__ import annotations

import contextlib
import html
import importlib
import json
import math
import os
import platform
import re
import shutil
import stat
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

from .._paths import _check_not_special
from ..errors import InputError, arg
from ..experiments.data import SectionData
from .html import Html, ReportPaths, ReportSection, Table, write_report
from .parts import render

__all__ = [
    "run_demo",
    "check_out_dir",
    "DEFAULT_EXPERIMENTS",
    "HEADLINE_TITLE",
    "INTRO_TITLE",
    "ERRATA_TITLE",
    "ADDS_TITLE",
    "YOUR_DATA_TITLE",
]

#: The paper reproductions run by default, as ``"module:function"`` (imported lazily).
DEFAULT_EXPERIMENTS = (
    "physid.experiments.manipulator_paper:run",
    "physid.experiments.msd_paper:run",
    "physid.experiments.arm6:run",
)
HEADLINE_TITLE = "What physid does, in one screen"
YOUR_DATA_TITLE = "Your data: three commands"
INTRO_TITLE = "About this report"
ERRATA_TITLE = "Errata summary"
ADDS_TITLE = "What physid adds beyond the papers"

_PAPERS = {
    "manipulator": "L. Cedro and D. Janecki, “Identification of a manipulator model using the "
    "input error method in the Mathematica program”",
    "msd": "M. Oueslati, S. Thiery, O. Gibaru, R. Béarée and G. Moraru, “On algebraic approach "
    "for MSD parametric estimation” (2011)",
}
#: Modules whose versions the report states when the demo imported them: (module, distribution).
_VERSIONED = (
    ("numpy", "numpy"),
    ("scipy", "scipy"),
    ("sympy", "sympy"),
    ("matplotlib", "matplotlib"),
    ("pandas", "pandas"),
    ("h5py", "h5py"),
    ("pint", "pint"),
    ("dask", "dask"),
    ("distributed", "distributed"),
    ("pinocchio", "pin"),
    ("pysindy", "pysindy"),
)

Experiment = Callable[..., Sequence[ReportSection | SectionData]]


def _resolve(experiment: str | Experiment) -> tuple[str, Experiment]:
    """A display name and the callable for ``"module:function"`` strings or callables."""
    if callable(experiment):
        name = getattr(experiment, "__module__", "") or ""
        name = f"{name}.{getattr(experiment, '__qualname__', type(experiment).__name__)}"
        return name.removeprefix("physid.experiments."), experiment
    if isinstance(experiment, str) and ":" in experiment:
        module_name, _, attr = experiment.partition(":")
        module = importlib.import_module(module_name)
        return module_name.removeprefix("physid.experiments."), getattr(module, attr)
    raise InputError(
        f"experiments must hold callables run(quick, progress) -> list[SectionData] or "
        f"'module:function' strings; got {experiment!r}."
    )


def _versions() -> tuple[list[tuple[str, str]], list[str]]:
    """Versions of what the demo imported, and the optional packages it did not need."""
    from .. import __version__

    rows = [("physid", __version__), ("Python", platform.python_version())]
    unused = []
    for module, dist in _VERSIONED:
        if module in sys.modules:
            try:
                rows.append((module, metadata.version(dist)))
            except metadata.PackageNotFoundError:  # imported from a source tree
                rows.append((module, str(getattr(sys.modules[module], "__version__", "?"))))
        else:
            unused.append(module)
    rows.append(("platform", f"{platform.system()} {platform.machine()}"))
    return rows, unused


def _intro_section(
    quick: bool, timings: list[tuple[str, int, float]], total_s: float, out_dir: Path
) -> ReportSection:
    command = "physid demo --quick" if quick else "physid demo"
    kind = "quick run: short records and small grids, for a fast check" if quick else "full run"
    versions, unused = _versions()
    paragraphs = [
        Html(
            f"Made by <code>{command} --out {html.escape(out_dir.name)}</code> "
            f"({kind}). Every data set is simulated by physid with fixed seeds, so running the "
            "command again gives the same numbers. All numbers shown are also in "
            "<code>results.json</code>, keyed by section title; every figure is also a PNG file "
            "beside this page."
        ),
        "The versions are those of the packages this run imported"
        + (
            "; optional packages it did not need (extras of physid): " + ", ".join(unused) + "."
            if unused
            else "."
        ),
    ]
    tables = [
        Table("Software versions (packages this run imported)", ("package", "version"), versions),
        Table(
            "Run time of each part of the demo",
            ("part", "report sections", "wall time [s]"),
            [(name, n, round(seconds, 2)) for name, n, seconds in timings]
            + [("total", sum(n for _, n, _ in timings), round(total_s, 2))],
        ),
    ]
    results = {
        "quick": quick,
        "versions": dict(versions),
        "not_imported": unused,
        "wall_time_s": {name: round(seconds, 2) for name, _, seconds in timings},
        "total_wall_time_s": round(total_s, 2),
        "cpu_count": os.cpu_count(),
    }
    return ReportSection(
        INTRO_TITLE, paragraphs=paragraphs, tables=tables, results=results, part=_END_PART
    )


_END_PART = "Reference: errata, versions, run times"


def _errata_section(sections: Sequence[ReportSection]) -> ReportSection:
    counts: dict[str, int] = {}
    where: dict[str, list[str]] = {}
    for s in sections:
        for e in s.errata:
            counts[e.paper] = counts.get(e.paper, 0) + 1
            where.setdefault(e.paper, [])
            if s.title not in where[e.paper]:
                where[e.paper].append(s.title)
    total = sum(counts.values())
    if total:
        paragraphs = [
            Html(
                f"We found {total} misprint(s) or error(s) in the two papers. The table "
                '<a href="#errata">Errata found in the papers</a> at the end lists each one with '
                "what is printed, what is correct and the evidence (a derivation, a number or a "
                "figure in this report)."
            ),
            "How we checked: formulas were derived again (symbolically, with sympy, where they are "
            "symbolic), the papers' code listings were transcribed and run, and each correction "
            "was checked numerically on a case where the printed and the corrected forms give "
            "visibly different answers (for example a well-damped system for the algebraic "
            "kernel, where the paper's lightly damped one hides a sign error).",
        ]
    else:
        paragraphs = ["The experiments reported no errata."]
    table = Table(
        "Errata per paper",
        ("paper", "errata", "sections with the evidence"),
        [(paper, n, "; ".join(where[paper])) for paper, n in counts.items()],
    )
    return ReportSection(
        ERRATA_TITLE,
        paragraphs=paragraphs,
        tables=(table,) if counts else (),
        results={"total": total, "per_paper": counts},
        part=_END_PART,
    )


def _number(value: Any) -> float | int | None:
    """``value`` as an int or float, or None when it is not a single number."""
    if isinstance(value, bool) or value is None:
        return None
    if isinstance(value, int):
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def _lookup_number(results: Mapping[str, Mapping[str, Any]], path: str) -> float | int | None:
    """The first number found under a dotted path ``"key.sub"`` in any section's results.

    ``"maxabs:path"`` takes the largest absolute value of the numbers in a list or mapping there.
    """
    aggregate, _, path = path.rpartition(":")
    for section_results in results.values():
        value: Any = section_results
        for key in path.split("."):
            value = value.get(key) if isinstance(value, Mapping) else None
        if aggregate == "maxabs" and isinstance(value, (Mapping, list, tuple)):
            items = value.values() if isinstance(value, Mapping) else value
            numbers = [abs(n) for n in map(_number, items) if n is not None and math.isfinite(n)]
            value = max(numbers) if numbers else None
        number = _number(value)
        if number is not None:
            return number
    return None


#: The rows of the "beyond the papers" table: key, capability, what the papers do, what physid
#: does, and the candidates for its number (dotted path into the results, what it means), the
#: first found wins.
_ADDS: tuple[tuple[str, str, str, str, list[tuple[str, str]]], ...] = (
    (
        "evaluations",
        "Input-error fit",
        "derivative-free search, about 1450 evaluations",
        "least squares with the analytic Jacobian of the generated equations of motion",
        [
            (
                "ours.nfev",
                "residual evaluations physid needed from the paper's initial values "
                "(paper: about 1450)",
            )
        ],
    ),
    (
        "kinetic_energy",
        "Kinetic energy",
        "keeps only the squared term of each joint rate (no cross terms)",
        "exact ½ m|v|² with all cross terms (default), and the paper's form to reproduce it",
        [
            (
                "paper_model_fitted_to_exact_data.m2",
                "m2 [kg] found when the paper's model is fitted to data of the exact arm (true 25 kg)",
            )
        ],
    ),
    (
        "identifiability",
        "Identifiability",
        "fits all 8 parameters",
        "names the combinations the data cannot separate (m1 and l1 enter only as m1·l1²) and "
        "holds one parameter of each",
        [("models_theta_rank", "rank of the 8 physical parameters in the equations of motion")],
    ),
    (
        "filters",
        "Differential filters",
        "fixed M = 100, Ω_g = 0.2; second-derivative filter normalised on t² only",
        "checks the pass band against the motion's spectrum and warns; derivative filters "
        "consistent with the low-pass remove the m1·l1² bias",
        [
            (
                "maxabs:ours_consistent_filters.errors_percent",
                "largest error [%] of the identifiable quantities with consistent filters, on the "
                "paper's data and model",
            )
        ],
    ),
    (
        "algebraic",
        "Algebraic estimator",
        "printed for order 2 only, with the window run backwards and Simpson's rule",
        "any order, kernels derived and generated automatically; exact integration rule; "
        "determinant guard; streaming in chunks with constant memory, equal to batch",
        [
            (
                "window_search.clean.shortest_window_s",
                "shortest window [s] with 95 % of windows within 2 % on clean data (exact rule)",
            )
        ],
    ),
    (
        "rls",
        "Recursive least squares",
        "covariance update that loses symmetry and overflows with λ < 1 without excitation",
        "Joseph-form update, symmetric and bounded; a vectorised batch form equal to the "
        "streaming one",
        [
            (
                "errata_evidence.eq3.printed_rows_to_overflow",
                "rows after which the printed update overflows (λ = 0.99, no excitation)",
            )
        ],
    ),
    (
        "input_design",
        "Input design",
        "optimum at Z = 1, from a variance formula with a spurious ω0",
        "the variance factor derived again; the optimum found numerically for each forgetting "
        "factor and horizon",
        [
            (
                "optimal_ratio_wide_range",
                "optimal Z = ω1/ω0 for the paper's k = 100, m = 3, λ = 1 (searched over [0.01, 20])",
            ),
            ("optimal_ratio", "optimal Z = ω1/ω0 for the paper's k = 100, λ = 1"),
        ],
    ),
    (
        "sweeps",
        "Monte-Carlo studies",
        "one run per condition",
        "SNR × Z × seed sweeps, each trial seeded from one root seed (same bits on any "
        "backend); local process pool or a Dask cluster",
        [("sweep.n_trials", "trials behind this report's convergence maps")],
    ),
)


def _adds_section(sections: Sequence[ReportSection]) -> ReportSection:
    """Capabilities beyond the papers, with the report's numbers where the sections give them."""
    results = {s.title: s.results for s in sections}
    # Each row: capability, what the papers do, what physid does, a number from the report.
    rows: list[tuple[str, str, str, Any, str]] = []
    picked: dict[str, Any] = {}
    for key, capability, paper, physid, candidates in _ADDS:
        # one row; its number is the first of ``candidates`` (dotted path, meaning) found
        for path, what in candidates:
            value = _lookup_number(results, path)
            if value is not None:
                picked[key] = {"value": value, "meaning": what, "source": path}
                rows.append((capability, paper, physid, value, what))
                break
        else:
            rows.append((capability, paper, physid, None, ""))
    rows.append(
        (
            "Your own system",
            "—",
            "model files (TOML), recordings from CSV / NPZ / MAT / HDF5, and the physid command",
            None,
            "",
        )
    )
    table = Table(
        "What physid does beyond the two papers (numbers from this report where available)",
        ("capability", "the papers", "physid", "number", "what the number is"),
        rows,
    )
    paragraphs = [
        "Beyond reproducing the papers, physid is a library for your own data. The table lists "
        "the differences in method; Parts I and II show their effect on the papers' own "
        "examples, Part III on a robot arm.",
        Html(
            'To run it on your own recordings, see <a href="#your-data-three-commands">Your '
            "data</a> and <code>docs/your-data.md</code>; to choose a method, "
            "<code>docs/choosing-an-estimator.md</code>."
        ),
    ]
    return ReportSection(
        ADDS_TITLE, paragraphs=paragraphs, tables=(table,), results=picked, part=_END_PART
    )


def _find(results: Mapping[str, Mapping[str, Any]], title: str, *path: str) -> Any:
    """``results[title][path...]`` or None."""
    value: Any = results.get(title)
    for key in path:
        value = value.get(key) if isinstance(value, Mapping) else None
    return value


def _manipulator_item(res, link) -> tuple[str, tuple[Any, str] | None]:
    """Part I's headline: its numbers and its list item (None when the section is missing)."""
    m = next((t for t in res if t.startswith("Manipulator: what the paper")), None)
    if m is None:
        return "manipulator", None
    r = res[m]
    picked = {
        k: r[k]
        for k in (
            "identifiable_rank",
            "paper_parameters_fitted",
            "our_residual_evaluations",
            "paper_evaluations",
            "consistent_combo_error_percent",
            "paper_combo_error_percent",
            "n_joints",
        )
    }
    item = (
        f"<li><strong>Part I, a {r['n_joints']}-DOF arm (Cedro &amp; Janecki):</strong> "
        f"{r['identifiable_rank']} identifiable parameters (of the "
        f"{r['paper_parameters_fitted']} the paper fits) in {r['our_residual_evaluations']} "
        f"evaluations (paper: about {r['paper_evaluations']}); m1·l1² within "
        f"{abs(r['consistent_combo_error_percent']):.2f} % with consistent filters (paper: "
        f"{r['paper_combo_error_percent']:+.2f} %). " + link(m, "Part I") + "</li>"
    )
    return "manipulator", (picked, item)


def _msd_item(res, link) -> tuple[str, tuple[Any, str] | None]:
    """Part II's headline: its numbers and its list item (None when the claims are missing)."""
    c = next((t for t in res if t.startswith("MSD: the paper's claims")), None)
    if c is None or "headline" not in res[c]:
        return "msd", None
    h = res[c]["headline"]
    item = (
        "<li><strong>Part II, a mass-spring-damper (Oueslati et al.):</strong> "
        f"ω0 within {100 * h['algebraic_final_error_25dB']:.2g} % at {h['snr_db']:g} dB from "
        "the algebraic estimator's pooled windows; RLS reaches 2 % only "
        f"{h['rls_over_algebraic_25dB']:.2g}× later at {h['snr_db']:g} dB, not the paper's "
        f"{h['paper_ratio']:g}×; {h['claims_hold']} of the "
        f"{h['claims']} claims checked {'holds' if h['claims_hold'] == 1 else 'hold'} as "
        "stated. " + link(c, "Part II") + "</li>"
    )
    return "msd", (h, item)


def _arm6_item(res, link) -> tuple[str, tuple[Any, str] | None]:
    """Part III's headline: its numbers and its list item (None when the section is missing)."""
    a = next((t for t in res if t.startswith("6-DOF arm: what")), None)
    if a is None:
        return "arm6", None
    r = res[a]
    if "iv_bias" in r and "held_out_error_iv" in r:
        keys = ("n_joints", "n_base", "iv_bias", "ols_bias", "held_out_error_iv", "n_seeds")
        picked = {k: r[k] for k in keys}
        body = (
            f"{r['n_base']} base parameters identified from noisy closed-loop records; the "
            "torque of a held-out trajectory is predicted within "
            f"{100 * r['held_out_error_iv']:.2g} % (IDIM-IV). "
            + (
                f"Bias the noise adds, over {r['n_seeds']} seeds: {100 * r['iv_bias']:.2g} % "
                f"by instrumental variables, {100 * r['ols_bias']:.2g} % by least squares."
                if r["n_seeds"] >= 5
                else f"This quick run has {r['n_seeds']} seeds, too few to separate bias "
                "from scatter: see the full run for the OLS/IV bias."
            )
        )
        arm = f"a {r['n_joints']}-DOF arm"
    else:
        picked = {"missing": r.get("missing", [])}
        body = "not run in this build; it needs " + "; ".join(r.get("missing", [])) + "."
        arm = "a robot arm"
    item = (
        f"<li><strong>Part III, {arm} from its URDF:</strong> "
        + html.escape(body)
        + " "
        + link(a, "Part III")
        + "</li>"
    )
    return "arm6", (picked, item)


def _headline_section(sections: Sequence[ReportSection]) -> ReportSection:
    """One screen: the headline result of each part beside the paper's number, with links."""
    from .html import _slug  # the page's anchors, made by the same function

    used: set[str] = {"errata", "toc"}
    slugs = {s.title: _slug(s.title, used) for s in sections}
    res = {s.title: dict(s.results) for s in sections}
    items: list[str] = []
    picked: dict[str, Any] = {}

    def link(title: str, text: str) -> str:
        return f'<a href="#{slugs[title]}">{html.escape(text)}</a>' if title in slugs else text

    for key, item in (
        _manipulator_item(res, link),
        _msd_item(res, link),
        _arm6_item(res, link),
    ):
        if item is not None:
            picked[key] = item[0]
            items.append(item[1])
    paragraphs = [
        "physid identifies the physical parameters of mechanical systems (masses, inertias, "
        "friction, stiffness, damping) from measured motion and force signals. This report "
        "reproduces two papers with it, side by side with their printed claims, lists where the "
        "papers are wrong, and identifies a robot arm end to end from its URDF.",
        Html('<ul class="headline">' + "".join(items) + "</ul>"),
        "Your own data comes next; the errata of the papers and the software versions close "
        "the report.",
    ]
    return ReportSection(HEADLINE_TITLE, paragraphs=paragraphs, results=picked)


def _your_data_section() -> ReportSection:
    """The three commands that take a user's own file through identify/estimate → validate."""
    import importlib.util

    def has(verb: str) -> bool:
        return importlib.util.find_spec(f"physid.cli.verb_{verb}") is not None

    missing = [v for v in ("identify", "estimate", "validate") if not has(v)]
    # identify's IDIM methods ship together with the design-excitation verb; the report
    # must not import the CLI (report sits below cli in the layers), so look the module up only
    idim_cli = has("identify") and has("design_excitation")
    method = " --method idim-iv --kp 400,400,200,50,50,20 --kd 40,40,20,5,5,2" if idim_cli else ""
    commands = (
        "# 1. a linear system from your own log: your column names and units, saved result\n"
        "physid estimate logger.csv --model my_msd.toml --method rls \\\n"
        "    --map t=Zeit,u=Kraft,x=Weg --decimal , --save fit.json\n"
        "# 2. the same fit checked on a log it has not seen\n"
        "physid validate fit.json heldout.csv --map t=Zeit,u=Kraft,x=Weg --decimal ,\n"
        "# 3. an arm: your log and your URDF (volts to torque with your drive gain)\n"
        f"physid identify arm_log.csv --model my_arm.urdf{method} \\\n"
        "    --map t=time,q1=pos1,tau1=gain*volt1 --json"
    )
    prints = (
        "$ physid estimate logger.csv ... --save fit.json\n"
        "RecursiveResult: success\n"
        "  theta1            = 0.015352951  ± 0.00843  [1/s]\n"
        "  theta2            = 133.26231  ± 0.0632  [1/s^2]\n"
        "  natural_frequency = 11.543929  ± 0.00274  (derived)  [rad/s]\n"
        "  fit 98.92 % (output-error fit on the fitted record)\n"
        "$ physid validate fit.json heldout.csv ...\n"
        "  (b) output error x: fit 98.91 %, relative error 0.01092\n"
        "  (c) residual is white and uncorrelated with the input (99 % band): ...\n"
        "$ physid identify arm_log.csv ...   (--json: one object; without it, a table)\n"
        "  torque fit (100 (1 − rms error / rms τ), filtered): tau1 99.1 %, tau2 98.7 %, ..."
    )
    paragraphs = [
        "From your own recording to an estimate, and a check of it on a held-out recording:",
        Html(f"<pre><code>{html.escape(commands)}</code></pre>"),
        "The channel map names your columns (and converts volts to torque with your drive "
        "gain); units in the header, such as deg or mm, are converted to SI. A file that lacks "
        "a channel gets the --map line that would fix it, built from its own column names.",
        "What they print (an RLS fit of a simulated mass-spring-damper, abridged; each value "
        "with its standard error and unit, then the fit):",
        Html(f"<pre><code>{html.escape(prints)}</code></pre>"),
        Html(
            "The walk-through, with a worked example on a logged linear-axis drive and on a "
            "mass-spring-damper, is <code>docs/your-data.md</code>; robots are covered in "
            "<code>docs/identifying-a-robot.md</code>."
        ),
    ]
    if missing:
        paragraphs.append(
            "Not in this build of physid yet: physid " + ", ".join(missing) + " (see the notes)."
        )
    return ReportSection(
        YOUR_DATA_TITLE,
        paragraphs=paragraphs,
        results={"verbs_missing": missing},
    )


def check_out_dir(out_dir: str | os.PathLike) -> Path:
    """``out_dir`` as a path, refused at once when it cannot become the report folder.

    Raises
    ------
    InputError
        ``out_dir`` is an existing file (not a folder), or its parent folder is a file.
    """
    out = Path(out_dir)
    named = arg("out_dir", repr(str(out)), cli=str(out))
    if out.exists() and not out.is_dir():
        raise InputError(
            f"{named} is an existing file, not a folder; the demo writes a folder "
            "(report.html, results.json, PNGs). Give a new or existing folder name."
        )
    for parent in out.absolute().parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(
                    f"{named}: {str(parent)!r} is a file, so the folder cannot be created there. "
                    "Choose another path."
                )
            break
    return out


def _stage(out: Path) -> Path:
    """A fresh staging folder beside ``out`` (same file system, so moving in is a rename)."""
    parent = out.absolute().parent
    parent.mkdir(parents=True, exist_ok=True)
    try:
        return Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
    except OSError as exc:
        raise InputError(
            f"{arg('out_dir', repr(str(out)), cli=str(out))}: cannot write into {str(parent)!r} "
            f"({exc.strerror}); choose a folder you can write to."
        ) from None


#: The files a report writes per figure: ``<name>.png``, names as `FigureSpec` allows them.
_FIGURE_FILE = re.compile(r"[A-Za-z0-9_-]+\.png")


def _move_in(staging: Path, out: Path) -> None:
    """Move the staged outputs into ``out``: one rename when ``out`` is new, else file by file.

    Figures of an earlier demo in ``out`` (listed in its results.json) that this run did not
    write are removed, so the folder never mixes two runs: only regular files named as the
    report names its PNGs, never a link, a special file or another name (a results.json that
    lists ``thesis.tex`` removes nothing). Each destination is checked as `atomic_write` checks
    its own (no link, FIFO or device is replaced); other files are left alone.
    """
    if not out.exists():
        os.replace(staging, out)
        return
    old: set[str] = set()
    with contextlib.suppress(OSError, ValueError, KeyError, TypeError, AttributeError):
        meta = json.loads((out / "results.json").read_text(encoding="utf-8"))["metadata"]
        old = {n for n in meta.get("figures", []) if isinstance(n, str)}
    new = {p.name for p in staging.iterdir()}
    for name in new:  # all before anything is moved: a refusal leaves the old run whole
        _check_not_special(out / name)
    for name in sorted(old - new):
        if not _FIGURE_FILE.fullmatch(name):
            continue
        with contextlib.suppress(FileNotFoundError):
            if stat.S_ISREG(os.lstat(out / name).st_mode):
                (out / name).unlink()
    # the page last: once it is replaced, every file it describes is in place
    for name in sorted(new, key=lambda n: n == "report.html"):
        _check_not_special(out / name)  # again: it may have appeared meanwhile
        os.replace(staging / name, out / name)
    staging.rmdir()


def run_demo(
    out_dir: str | os.PathLike = "demo-out",
    quick: bool = False,
    progress: Callable[[str], None] | None = None,
    experiments: Sequence[str | Experiment] | None = None,
) -> ReportPaths:
    """Run the experiments and write the report.

    Parameters
    ----------
    out_dir : path
        Folder for ``report.html``, ``results.json`` and the PNG figures (created if missing;
        checked before anything runs). The outputs are written to a staging folder beside it and
        moved in at the end.
    quick : bool
        Short records, small grids and fewer seeds: the whole demo in under a minute.
    progress : callable, optional
        Called with short progress messages (the CLI prints them on stderr).
    experiments : sequence of callables or ``"module:function"`` strings, optional
        Each is called as ``run(quick=quick, progress=progress)`` and returns a list of
        `SectionData` (rendered by `physid.report.parts`) or of ready `ReportSection`.
        Default: `DEFAULT_EXPERIMENTS`.

    Returns
    -------
    ReportPaths
        Paths of the HTML page, the JSON results and the figures (inside ``out_dir``).

    Raises
    ------
    InputError
        ``out_dir`` is a file or cannot be written; an experiment is neither callable nor a
        ``"module:function"`` string, or returns something other than sections.
    """
    say = progress or (lambda message: None)
    out = check_out_dir(out_dir)
    chosen = DEFAULT_EXPERIMENTS if experiments is None else tuple(experiments)
    staging = _stage(out)
    try:
        paper_sections: list[ReportSection] = []
        timings: list[tuple[str, int, float]] = []
        start = time.perf_counter()
        for experiment in chosen:
            name, run = _resolve(experiment)
            say(f"demo: running {name} ({'quick' if quick else 'full'}) ...")
            t0 = time.perf_counter()
            sections = list(run(quick=quick, progress=progress))
            rendered = []
            for s in sections:
                if isinstance(s, SectionData):
                    s = render(s)
                if not isinstance(s, ReportSection):
                    raise InputError(
                        f"experiment {name} returned a {type(s).__name__}; it must return a list "
                        "of physid.experiments.data.SectionData (or report sections)."
                    )
                rendered.append(s)
            seconds = time.perf_counter() - t0
            say(f"demo: {name} done in {seconds:.1f} s ({len(rendered)} section(s))")
            paper_sections.extend(rendered)
            timings.append((name, len(rendered), seconds))
        total = time.perf_counter() - start
        sections = [
            _your_data_section(),  # right after the one-screen summary: a user's own data
            *paper_sections,
            _adds_section(paper_sections),
            _errata_section(paper_sections),
            _intro_section(quick, timings, total, out),
        ]
        sections.insert(0, _headline_section(sections))
        say(f"demo: writing the report to {out} ...")
        paths = write_report(
            sections,
            staging,
            title="physid: what it finds, on two papers and a 6-DOF arm",
            quick=quick,
            errata_after=len(sections),  # the full errata table closes the report
            lead=2,  # the one-screen summary and "your data" come before the contents
            metadata={
                "command": "physid demo" + (" --quick" if quick else ""),
                "python": sys.version.split()[0],
            },
            progress=say,
        )
        _move_in(staging, out)
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
    say(f"demo: done in {time.perf_counter() - start:.1f} s")
    return ReportPaths(
        html=out / paths.html.name,
        json=out / paths.json.name,
        figures=tuple(out / p.name for p in paths.figures),
    )
