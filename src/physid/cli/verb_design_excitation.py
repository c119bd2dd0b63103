"""``physid design-excitation MODEL``: an optimal Fourier excitation for rigid-body identification.

Writes the designed trajectory as a recording of references ``r1..rn`` [rad] (with their rates
``rd1..rdn`` and accelerations ``rdd1..rddn``) that ``physid simulate MODEL --reference FILE`` can
run, and prints the achieved condition number of the column-scaled base regressor against the
medians of two random baselines under the same limits (Swevers et al. 1997): random Fourier
trajectories scaled to touch the limits, and the same at random amplitudes within the limits.
"""

from __future__ import annotations

from .._resources import check_memory
from ..errors import InputError
from ._common import check_recording_path, float_list, print_json, progress

ORDER = 45
#: Keywords of `design_excitation` whose flag is not spelled like them.
ARGUMENT_FLAGS = {
    "n_random": "--random",
    "n_starts": "--starts",
    "q_start": None,
    "n_grid": None,
}

__all__ = ["ORDER", "register", "run"]


def register(subparsers) -> None:
    """Add the ``design-excitation`` verb."""
    p = subparsers.add_parser(
        "design-excitation",
        help="design a Fourier excitation trajectory that minimises the base regressor's "
        "condition number",
        description=(
            "Design finite-Fourier-series joint trajectories (Swevers et al. 1997) that start "
            "and end at rest, respect the position, velocity and acceleration limits (from the "
            "model, e.g. a URDF's <limit>, or given here), and minimise the condition number of "
            "the base regressor (or maximise log det of its information matrix). Writes t, "
            "r1..rn [rad], rd1..rdn [rad/s], rdd1..rddn [rad/s^2]."
        ),
    )
    p.add_argument("model", help="'manipulator', 'arm6', a TOML or a URDF model file")
    p.add_argument("--out", required=True, metavar="F", help="output recording (.csv or .npz)")
    p.add_argument("--harmonics", type=int, default=5, help="harmonics per joint (default: 5)")
    p.add_argument("--period", type=float, default=10.0, help="period [s] (default: 10)")
    p.add_argument("--periods", type=int, default=1, help="periods written (default: 1)")
    p.add_argument("--dt", type=float, default=1e-3, help="sample period [s] (default: 0.001)")
    p.add_argument(
        "--criterion",
        choices=("cond", "logdet"),
        default="cond",
        help="minimise the condition number, or maximise log det (default: cond)",
    )
    p.add_argument(
        "--velocity", default=None, metavar="LIST", help="velocity limits [rad/s] per joint"
    )
    p.add_argument(
        "--acceleration",
        default=None,
        metavar="LIST",
        help="acceleration limits [rad/s^2] per joint (default: the model's, else 5x velocity)",
    )
    p.add_argument(
        "--position",
        default=None,
        metavar="LO,HI,...",
        help="position limits [rad], a pair per joint (default: the model's, else ±π)",
    )
    p.add_argument(
        "--optimise-start",
        action="store_true",
        help="make the rest position a design variable (default: start at 0, clipped into "
        "the limits); the trajectory then starts away from zero: move the robot there first",
    )
    p.add_argument("--random", type=int, default=20, help="random trajectories to compare (20)")
    p.add_argument(
        "--starts",
        type=int,
        default=4,
        help="optimiser starts, the best random trajectories (default: 4)",
    )
    p.add_argument(
        "--max-iter", type=int, default=400, help="optimiser iterations per start (default: 400)"
    )
    p.add_argument(
        "--max-seconds",
        type=float,
        default=60.0,
        help="wall-time budget of the optimiser [s] (default: 60)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the random draws (default: 0)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(func=run)


def _limits(args, model):
    """The position, velocity and acceleration limits given on the command line (None: none)."""
    import numpy as np

    position = None
    if args.position:
        values = float_list(args.position, "--position")
        if len(values) != 2 * model.n_joints:
            raise InputError(
                f"--position expects a LO,HI pair per joint ({2 * model.n_joints} numbers); got "
                f"{len(values)}."
            )
        position = np.reshape(values, (model.n_joints, 2))
    velocity = float_list(args.velocity, "--velocity") if args.velocity else None
    acceleration = float_list(args.acceleration, "--acceleration") if args.acceleration else None
    for name, v in (("--velocity", velocity), ("--acceleration", acceleration)):
        if v is not None and len(v) not in (1, model.n_joints):
            raise InputError(
                f"{name} expects one value or one per joint ({model.n_joints}); got {len(v)}."
            )
    return position, velocity, acceleration


def _check_grid(args, model) -> None:
    """Refuse a sample grid that is malformed, too coarse for the harmonics, or too large."""
    import numpy as np

    if args.periods < 1:
        raise InputError(f"--periods must be a positive integer; got {args.periods}.")
    if not args.dt > 0 or args.dt > args.period / (4 * args.harmonics):
        raise InputError(
            f"--dt must be positive and resolve the highest harmonic (≤ period/(4·harmonics) = "
            f"{args.period / (4 * args.harmonics):g} s); got {args.dt}."
        )
    if not (np.isfinite(args.period) and args.period > 0):
        raise InputError(f"--period must be a positive number of seconds; got {args.period}.")
    samples = args.periods * args.period / args.dt + 1
    if samples > 5e7:
        raise InputError(
            f"--periods {args.periods} × --period {args.period:g} s at --dt {args.dt:g} s asks for "
            f"{samples:.3g} samples; at most 5e7 (raise --dt, or shorten --period/--periods)."
        )
    check_memory(
        3.0 * 8.0 * samples * (4 * model.n_joints + 1),  # t, q, qd, qdd, r and the CSV text
        what=f"design-excitation with {samples:.3g} samples × {4 * model.n_joints + 1} channels",
        fix="raise --dt, or shorten --period/--periods",
    )


def _summary(args, design) -> dict:
    """The design's numbers for ``--json``."""
    return {
        "out": str(args.out),
        "condition_number": design.condition_number,
        "random_median_condition_number": design.random_median,
        "improvement": design.improvement,
        "random_within_median_condition_number": design.random_within_median,
        "improvement_within": design.improvement_within,
        "random_condition_numbers": design.random_condition_numbers,
        "random_within_condition_numbers": design.random_within_condition_numbers,
        "unscaled_condition_number": design.unscaled,
        "starts": list(design.starts),
        "seconds": design.seconds,
        "q_start": design.q_start,
        "log_det": design.log_det,
        "harmonics": design.harmonics,
        "period": design.period,
        "peak": design.peak,
        "limits": design.limits,
    }


def run(args) -> int:
    """Design, write, print; returns 0."""
    import physid

    from ..analysis.excitation import design_excitation
    from ..signals import save_recording

    check_recording_path(args.out, "--out")  # before the design, not after it

    model = physid.load_model(args.model)
    position, velocity, acceleration = _limits(args, model)
    _check_grid(args, model)
    progress(f"design-excitation: {model.n_joints} joints, {args.harmonics} harmonics")
    design = design_excitation(
        model,
        harmonics=args.harmonics,
        period=args.period,
        criterion=args.criterion,
        position=position,
        velocity=velocity,
        acceleration=acceleration,
        q_start="optimise" if args.optimise_start else None,
        n_random=args.random,
        n_starts=args.starts,
        max_iter=args.max_iter,
        max_seconds=args.max_seconds,
        seed=args.seed,
    )
    rec = design.to_recording(dt=args.dt, periods=args.periods)
    save_recording(rec, args.out)
    if args.json:
        print_json(_summary(args, design))
    else:
        progress(design.summary())
        print(args.out)
    return 0
