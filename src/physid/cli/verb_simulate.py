"""``physid simulate manipulator|msd|MODEL --out F.csv [...]``: write a simulated recording.

* ``MODEL`` (a ``.toml``/``.urdf`` chain file or the built-in ``arm6``): PD closed loop of any
  chain model following ``--reference`` → t, q1..qn, qd1..qdn, tau1..taun, r1..rn. A structure
  model (``kind = "structure"``) is driven open loop by the forces and base displacements of
  the ``--reference`` file → t, the inputs, the outputs.

* ``manipulator``: the closed-loop PD experiment of Cedro & Janecki (section 4) → t, q1..q4,
  qd1..qd4, tau1..tau4, r1..r4.
* ``msd``: the mass-spring-damper of Oueslati et al. (section 5), simulated exactly for
  u = A sin(Z ω0 t) → t, u, x (+ x_true when noise or a disturbance was added). ``u`` is the
  right-hand side of ẍ + θ1 ẋ + θ2 x = u, i.e. force / mass [m/s²].
"""

from __future__ import annotations

import argparse
import math
import re
import time

from ..errors import InputError
from ._common import check_recording_path, float_list, progress
from ._recordings import add_recording_options, read_recording

ORDER = 20


class _AnyName(dict):
    """Sub-command choices that accept any name (unknown names become ``model MODEL``)."""

    def __contains__(self, key):
        return True


class _SystemOrModel(argparse._SubParsersAction):
    """Sub-commands ``manipulator`` and ``msd``; any other name is a chain model (``model``)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if values and values[0] not in self._name_parser_map and not values[0].startswith("-"):
            values = ["model", *values]
        super().__call__(parser, namespace, values, option_string)


def register(subparsers) -> None:
    """Add the ``simulate`` verb.

    Long by design: a flat argparse declaration, one ``add_argument`` per option.
    """
    parser = subparsers.add_parser(
        "simulate",
        help="simulate the papers' experiments and write a recording",
        description=(
            "Simulate the closed-loop manipulator of Cedro & Janecki or the mass-spring-damper of "
            "Oueslati et al. and write the recording (.csv or .npz). Progress goes to stderr; the "
            "output path is printed on stdout."
        ),
    )
    systems = parser.add_subparsers(dest="system", metavar="SYSTEM", action=_SystemOrModel)
    systems.required = True
    _register_model(systems)

    arm = systems.add_parser(
        "manipulator",
        help="closed-loop PD run of the 4-DOF arm (Cedro & Janecki, section 4)",
        description=(
            "PD control of the 4-DOF arm following 0.5 rad filtered steps at 1, 3, 5, 7 s "
            "(Kp = 3800, 40000, 10000, 500; Kd = 159.5, 120, 50, 2), Δ = 1 ms, 0 .. 9.7 s. "
            "Writes t, q1..q4 [rad], qd1..qd4 [rad/s], tau1..tau4 [N·m], r1..r4 [rad]."
        ),
    )
    arm.add_argument("--out", metavar="F", required=True, help="output file (.csv or .npz)")
    arm.add_argument(
        "--kinetic",
        choices=["exact", "paper"],
        default="exact",
        help="kinetic energy of the model: exact, or the paper's simplified sum (default: exact)",
    )
    arm.add_argument(
        "--alignment",
        choices=["paper", "centred"],
        default="paper",
        help="time stamps of the filtered reference: 'paper' starts it at t = 0 (it leads the "
        "raw steps by 0.1 s, as in the paper's code); 'centred' is zero-phase (default: paper)",
    )
    arm.add_argument(
        "--noise-std",
        metavar="RAD",
        default=None,
        help="white noise std on q [rad] (default: none)",
    )
    arm.add_argument(
        "--seed",
        metavar="N",
        default=None,
        help="noise seed (non-negative integer; needs --noise-std)",
    )
    arm.set_defaults(func=run_manipulator)

    msd = systems.add_parser(
        "msd",
        help="exact simulation of the mass-spring-damper (Oueslati et al., section 5)",
        description=(
            "ẍ + θ1 ẋ + θ2 x = u with u = A sin(Z ω0 t), simulated exactly (matrix exponential). "
            "Default system: m = 3 kg, c = 0.05 N·s/m, k = 400 N/m; A = 1000/3 m/s² (the paper's "
            "A1 = 333.33 on the normalised equation, i.e. 1000 N on 3 kg); Δ = 1 ms; 5 s. "
            "Writes t, u [m/s²], x [m] (+ x_true [m] when noise or a disturbance is added)."
        ),
    )
    msd.add_argument("--out", metavar="F", required=True, help="output file (.csv or .npz)")
    msd.add_argument("--mass", metavar="KG", default=None, help="mass m [kg] (default: 3)")
    msd.add_argument("--stiffness", metavar="N_PER_M", default=None, help="k [N/m] (default: 400)")
    msd.add_argument(
        "--damping", metavar="NS_PER_M", default=None, help="c [N·s/m] (default: 0.05)"
    )
    msd.add_argument(
        "--natural-frequency", metavar="RAD_S", default=None, help="ω0 [rad/s] instead of k, c"
    )
    msd.add_argument("--damping-ratio", metavar="Z", default=None, help="ζ instead of k, c")
    msd.add_argument(
        "--amplitude",
        metavar="A",
        default=None,
        help="amplitude of u = F/m [m/s²] (default: 1000/3)",
    )
    msd.add_argument(
        "--force", metavar="N", default=None, help="force amplitude [N] (needs --mass)"
    )
    msd.add_argument("--ratio", metavar="Z", default="1", help="Z = ω1 / ω0 (default: 1)")
    msd.add_argument("--duration", metavar="S", default="5", help="duration [s] (default: 5)")
    msd.add_argument(
        "--dt", metavar="S", default="0.001", help="sample period [s] (default: 0.001)"
    )
    msd.add_argument(
        "--snr",
        metavar="DB",
        default=None,
        help="white noise on x at this SNR [dB] (default: none)",
    )
    msd.add_argument(
        "--disturbance",
        metavar="A2,W2",
        default=None,
        help="add A2 sin(W2 t) to x (A2 [m], W2 [rad/s]); 'paper' = 0.1 m at 500 ω0",
    )
    msd.add_argument(
        "--jumps",
        metavar="T:K,...",
        default=None,
        help="stiffness jumps: from time T [s] on, k = K [N/m] (position and velocity continuous)",
    )
    msd.add_argument(
        "--initial", metavar="X0,V0", default=None, help="x(0) [m], ẋ(0) [m/s] (default: 0,0)"
    )
    msd.add_argument(
        "--seed", metavar="N", default=None, help="noise seed (non-negative integer; needs --snr)"
    )
    msd.set_defaults(func=run_msd)
    systems.choices = _AnyName(systems._name_parser_map)


def _number(text, option: str, *, positive: bool = False, allow_zero: bool = False) -> float | None:
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{option} expects a number; got {text!r}.") from None
    if not math.isfinite(value):
        raise InputError(f"{option} must be finite; got {text!r}.")
    if positive and not (value > 0 or (allow_zero and value == 0)):
        rule = ">= 0" if allow_zero else "> 0"
        raise InputError(f"{option} must be {rule}; got {text!r}.")
    return value


def _seed(text) -> int | None:
    if text is None:
        return None
    try:
        seed = int(text)
    except ValueError:
        raise InputError(f"--seed expects a non-negative integer; got {text!r}.") from None
    if seed < 0:
        raise InputError(f"--seed expects a non-negative integer; got {text!r}.")
    return seed


def _jumps(text) -> list[tuple[float, float]] | None:
    if not text:
        return None
    out = []
    for item in text.split(","):
        if not item.strip():
            continue
        when, sep, value = item.partition(":")
        if not sep:
            raise InputError(
                f"--jumps expects TIME:STIFFNESS pairs such as 0.1:600,2.5:300; got {item!r}."
            )
        out.append(
            (
                _number(when.strip(), "--jumps time [s]"),
                _number(value.strip(), "--jumps stiffness [N/m]", positive=True),
            )
        )
    return out


def _grid(args) -> tuple[float, float]:
    """``--duration`` and ``--dt`` of ``simulate msd``, at most 5e7 samples (the memory check of
    `physid.simulate.simulate_msd` follows, with this machine's numbers)."""
    duration = _number(args.duration, "--duration [s]", positive=True)
    dt = _number(args.dt, "--dt [s]", positive=True)
    if duration / dt > 5e7:
        raise InputError(
            f"--duration {duration:g} s at --dt {dt:g} s asks for {duration / dt:.3g} samples; "
            "at most 5e7 (raise --dt, or shorten --duration)."
        )
    return duration, dt


def run_manipulator(args) -> int:
    from ..signals import save_recording
    from ..simulate import paper_manipulator_experiment

    check_recording_path(args.out, "--out")  # before the simulation, not after it

    noise = _number(args.noise_std, "--noise-std", positive=True, allow_zero=True)
    seed = _seed(args.seed)
    if seed is not None and noise is None:
        raise InputError("--seed only seeds the measurement noise; give --noise-std RAD as well.")
    progress(f"physid simulate manipulator: kinetic={args.kinetic}, reference={args.alignment} ...")
    start = time.perf_counter()
    rec = paper_manipulator_experiment(
        kinetic=args.kinetic, paper=args.alignment == "paper", noise_std=noise, seed=seed
    )
    wall = time.perf_counter() - start  # reported on stderr, never written into the file
    path = save_recording(rec, args.out)
    integ = rec.metadata["integrator"]
    progress(
        f"physid simulate manipulator: {rec.n_samples} samples, 0..{rec.t[-1]:.6g} s, "
        f"{integ['nfev']} right-hand-side calls in {wall:.2f} s "
        f"({integ['backend']})"
    )
    print(path)
    return 0


def run_msd(args) -> int:
    from ..signals import save_recording
    from ..signals.noise import alias_frequency
    from ..simulate import msd_paper_scenario

    check_recording_path(args.out, "--out")  # before the simulation, not after it

    mass = _number(args.mass, "--mass [kg]", positive=True)
    stiffness = _number(args.stiffness, "--stiffness [N/m]", positive=True)
    damping = _number(args.damping, "--damping [N·s/m]", positive=True, allow_zero=True)
    w0 = _number(args.natural_frequency, "--natural-frequency [rad/s]", positive=True)
    zeta = _number(args.damping_ratio, "--damping-ratio", positive=True, allow_zero=True)
    if (w0 is not None or zeta is not None) and (stiffness is not None or damping is not None):
        raise InputError(
            "give the system either as --stiffness/--damping (with --mass) or as "
            "--natural-frequency/--damping-ratio, not both."
        )
    amplitude = _number(args.amplitude, "--amplitude [m/s²]")
    force = _number(args.force, "--force [N]")
    if amplitude is not None and force is not None:
        raise InputError("give either --amplitude (of u = F/m, m/s²) or --force (N, with --mass).")
    if force is not None and mass is None:
        raise InputError("--force [N] needs --mass [kg] to form u = F/m; or give --amplitude.")
    disturbance = None
    if args.disturbance:
        if args.disturbance.strip() == "paper":
            disturbance = "paper"
        else:
            values = float_list(args.disturbance, "--disturbance")
            if len(values) != 2:
                raise InputError(
                    f"--disturbance expects A2,W2 (amplitude [m], angular frequency [rad/s]) or "
                    f"'paper'; got {args.disturbance!r}."
                )
            disturbance = tuple(values)
    seed = _seed(args.seed)
    if seed is not None and args.snr is None:
        raise InputError(
            "--seed only seeds the measurement noise; give --snr DB as well (the --disturbance "
            "sinusoid is deterministic), or drop --seed."
        )
    duration, dt = _grid(args)
    x0 = (0.0, 0.0)
    if args.initial:
        x0 = tuple(float_list(args.initial, "--initial"))
        if len(x0) != 2:
            raise InputError(f"--initial expects X0,V0 (m, m/s); got {args.initial!r}.")
    rec = msd_paper_scenario(
        ratio=_number(args.ratio, "--ratio", positive=True, allow_zero=True),
        snr_db=_number(args.snr, "--snr [dB]"),
        duration=duration,
        dt=dt,
        amplitude=amplitude,
        force_amplitude=force,
        disturbance=disturbance,
        jumps=_jumps(args.jumps),
        seed=seed,
        mass=3.0 if mass is None else mass,
        damping=damping,
        stiffness=stiffness,
        natural_frequency=w0,
        damping_ratio=zeta,
        x0=x0,
    )
    path = save_recording(rec, args.out)
    meta = rec.metadata
    text = (
        f"physid simulate msd: ω0 = {meta['natural_frequency']:.6g} rad/s, "
        f"ζ = {meta['damping_ratio']:.4g}, ω1 = {meta['angular_frequency']:.6g} rad/s, "
        f"{rec.n_samples} samples"
    )
    if "disturbance" in meta:
        d = meta["disturbance"]
        text += (
            f"; disturbance at {d['angular_frequency']:.6g} rad/s appears at "
            f"{alias_frequency(d['angular_frequency'], rec.dt):.6g} rad/s after sampling"
        )
    progress(text)
    print(path)
    return 0


# ------------------------------------------------------------------------- any chain model
def _register_model(systems) -> None:
    chain = systems.add_parser(
        "model",
        help="closed-loop PD run of any chain model: physid simulate MODEL.toml|MODEL.urdf|arm6",
        description=(
            "PD control τ = Kp (r − q) − Kd q̇ of a chain model (a .toml or .urdf file, or the "
            "built-in arm6) following a reference, integrated with DOP853. Writes t, q1..qn, "
            "qd1..qdn, tau1..taun, r1..rn (rad or m for prismatic joints). Usage: physid simulate "
            "MODEL --out F.csv."
        ),
    )
    chain.add_argument(
        "model",
        metavar="MODEL",
        help='model file (.toml, .urdf) or arm6; a structure model (kind = "structure") is '
        "driven by the inputs of --reference (docs/structures.md)",
    )
    chain.add_argument("--out", metavar="F", required=True, help="output file (.csv or .npz)")
    chain.add_argument(
        "--reference",
        metavar="F|LIST",
        default=None,
        help="a recording with t and r1..rn (e.g. from design-excitation), or n comma-separated "
        "set-points; default: a smooth multi-sine of 0.3 rad (0.05 m) per joint. Structure "
        "models: a recording of every force [N] and base displacement [m] (required)",
    )
    chain.add_argument(
        "--kp",
        metavar="LIST",
        default=None,
        help="proportional gains, one or one per joint (default: (2π·3 Hz)² M_jj at q = 0)",
    )
    chain.add_argument(
        "--kd",
        metavar="LIST",
        default=None,
        help="derivative gains, one or one per joint (default: critically damped, 2·2π·3 Hz·M_jj)",
    )
    chain.add_argument(
        "--feedforward",
        choices=("none", "gravity", "gravity+friction"),
        default="none",
        help="rigid-body models: the controller adds the model's gravity torque (and friction) "
        "to the PD law (default: none); the metadata's controller says which law ran",
    )
    chain.add_argument(
        "--duration",
        metavar="S",
        default=None,
        help="duration [s] (default: 5); with a --reference file: the file's length, or at most it",
    )
    chain.add_argument(
        "--dt", metavar="S", default="0.001", help="sample period [s] (default 1 ms)"
    )
    chain.add_argument(
        "--noise-std",
        metavar="RAD",
        default=None,
        help="white noise std on q (structure models: on every output, in its unit)",
    )
    chain.add_argument("--seed", metavar="N", default=None, help="noise seed (needs --noise-std)")
    add_recording_options(chain, what="the --reference file", detrend=False)
    chain.set_defaults(func=run_model)


def _is_number_list(text: str) -> bool:
    """Whether ``text`` is comma-separated numbers (set-points) rather than a file name."""
    try:
        return all(float(x) == float(x) for x in text.split(",")) and bool(text.strip())
    except ValueError:
        return False


def _no_reading_options(args) -> None:
    """Refuse ``--map``/``--decimal``/... without a ``--reference`` file they could apply to."""
    given = [
        flag
        for flag, value in (
            ("--map", getattr(args, "channel_map", None)),
            ("--decimal", getattr(args, "decimal", ".") != "."),
            ("--delimiter", getattr(args, "delimiter", None)),
            ("--resample", getattr(args, "resample", False)),
        )
        if value
    ]
    if given:
        raise InputError(
            f"{', '.join(given)} appl{'y' if len(given) > 1 else 'ies'} to a --reference file; "
            f"got no file (--reference {args.reference!r}). Give --reference F.csv, or leave "
            f"{'them' if len(given) > 1 else 'it'} out."
        )


def _gains(text, option, n, default):
    import numpy as np

    if text is None:
        return default
    values = float_list(text, option)
    if len(values) == 1:
        values = values * n
    if len(values) != n:
        raise InputError(f"{option} expects 1 or {n} gains (one per joint); got {len(values)}.")
    arr = np.array(values)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InputError(f"{option} gains must be finite and >= 0; got {text!r}.")
    return arr


def _default_reference(model, t, duration):
    """The default reference [rad or m]: slow sines of 0.3 rad (0.05 m) per joint, faded in over
    the first second and centred in the joints' limits where they are narrow."""
    import numpy as np

    n = model.n_joints
    types = getattr(model, "joint_types", ("revolute",) * n)
    amp = np.array([0.05 if k == "prismatic" else 0.3 for k in types])
    freq = 0.1 * (1.0 + 0.37 * np.arange(n))
    env = 0.5 * (1 - np.cos(np.pi * np.clip(t / min(1.0, duration), 0, 1)))
    reference = amp * env[:, None] * np.sin(2 * np.pi * freq * t[:, None])
    limits = getattr(model, "limits", None)
    if limits is not None:
        lo, hi = limits["position"][:, 0], limits["position"][:, 1]
        mid = np.where(np.isfinite(lo) & np.isfinite(hi), 0.5 * (lo + hi), 0.0)
        mid = np.where((mid > lo + amp) & (mid < hi - amp), 0.0, mid)
        reference = reference + mid
    return reference


def _file_reference(args, n, dt, duration, given_duration):
    """The reference read from ``--reference FILE``: (r1..rn, the file's time grid, the
    simulation's time grid); errors in CLI words."""
    import numpy as np

    # of the model file's [recording] table only t and r1..rn apply
    rec = read_recording(
        args,
        args.reference,
        table_channels=lambda c: c == "t" or re.fullmatch(r"r\d+", c) is not None,
    )
    names = [f"r{j + 1}" for j in range(n)]
    missing = [c for c in names if c not in rec.names]
    if missing:
        raise InputError(
            f"--reference {args.reference!r} has no channel(s) {missing}; it needs t and r1..r{n}."
        )
    span = float(rec.t[-1] - rec.t[0])
    if given_duration and duration > span * (1 + 1e-9):
        raise InputError(
            f"--duration {duration:g} s is longer than the --reference file "
            f"({span:g} s); give at most {span:g}, or leave --duration out."
        )
    span = duration if given_duration else span
    if span / dt > 5e7:
        raise InputError(
            f"--reference {args.reference!r} at --dt {dt:g} asks for {span / dt:.3g} "
            "samples; at most 5e7 (raise --dt, or give a shorter --duration)."
        )
    t = np.arange(int(round(span / dt)) + 1) * dt + rec.t[0]
    return rec.select(names).data, rec.t, t


def run_model(args) -> int:
    import numpy as np

    from ..models import ChainModel, load_model
    from ..signals import save_recording
    from ..simulate import simulate_closed_loop

    check_recording_path(args.out, "--out")  # before the simulation, not after it

    model = load_model(args.model)
    if hasattr(model, "nodes") and hasattr(model, "base_names"):
        return _run_structure(args, model)
    if not isinstance(model, ChainModel):
        raise InputError(
            f"{args.model!r} is a {type(model).__name__}, not a chain model; simulate it with "
            "physid simulate msd, or give a chain model (.toml with [[joints]] or .urdf)."
        )
    n = model.n_joints
    given_duration = args.duration is not None
    duration = _number(args.duration if given_duration else "5", "--duration [s]", positive=True)
    dt = _number(args.dt, "--dt [s]", positive=True)
    reference_file = args.reference is not None and not _is_number_list(args.reference)
    if not reference_file:
        _no_reading_options(args)
    if not reference_file and duration / dt > 5e7:
        raise InputError(f"--duration/--dt asks for {duration / dt:.3g} samples; at most 5e7.")
    noise = _number(args.noise_std, "--noise-std", positive=True, allow_zero=True)
    seed = _seed(args.seed)
    if seed is not None and noise is None:
        raise InputError("--seed only seeds the measurement noise; give --noise-std as well.")
    M0 = model.mass_matrix(np.zeros((1, n)))[0]
    w = 2 * np.pi * 3.0
    kp = _gains(args.kp, "--kp", n, w**2 * np.diag(M0))
    kd = _gains(args.kd, "--kd", n, 2 * w * np.diag(M0))
    t = np.arange(int(round(duration / dt)) + 1) * dt
    grid = None
    if args.reference is None:
        reference = _default_reference(model, t, duration)
    elif reference_file:
        reference, grid, t = _file_reference(args, n, dt, duration, given_duration)
    else:
        values = float_list(args.reference, "--reference")
        if len(values) != n:
            raise InputError(f"--reference expects {n} set-points; got {len(values)}.")
        reference = np.array(values)
    progress(f"physid simulate {args.model}: {n} joints, {t.size} samples ...")
    start = time.perf_counter()
    rec = simulate_closed_loop(
        model,
        kp=kp,
        kd=kd,
        reference=reference,
        t=t,
        noise_std=noise,
        rng=seed,
        reference_grid=grid,
        feedforward=getattr(args, "feedforward", "none"),
    )
    wall = time.perf_counter() - start  # reported on stderr, never written into the file
    path = save_recording(rec, args.out)
    integ = rec.metadata["integrator"]
    progress(
        f"physid simulate {args.model}: {integ['nfev']} right-hand-side calls in "
        f"{wall:.2f} s ({integ['backend']})"
    )
    print(path)
    return 0


def _run_structure(args, model) -> int:
    """``physid simulate STRUCTURE.toml --reference inputs.csv --out F``: the structure driven
    by the file's forces and base displacements (linear between samples), on the file's grid."""
    import numpy as np

    from ..signals import save_recording
    from ..simulate.structure import simulate_structure

    given = [f for f, v in (("--kp", args.kp), ("--kd", args.kd)) if v is not None]
    given += ["--feedforward"] if getattr(args, "feedforward", "none") != "none" else []
    given += ["--dt"] if args.dt != "0.001" else []
    if given:
        raise InputError(
            f"{', '.join(given)} do(es) not apply to structure model {model.name!r}: it runs open "
            "loop on the --reference file's inputs and time grid; drop it."
        )
    if args.reference is None or _is_number_list(args.reference):
        raise InputError(
            f"structure model {model.name!r} needs --reference FILE with t and its inputs "
            f"{list(model.input_names)} (forces [N], base displacements [m])."
        )
    rec = read_recording(args, args.reference)
    missing = [c for c in model.input_names if c not in rec.names]
    if missing:
        raise InputError(
            f"--reference {args.reference!r} has no channel(s) {missing} of {args.model!r} (it "
            f"has {list(rec.names)}); it needs t and {list(model.input_names)}."
        )
    model.check_units(rec)
    if args.duration is not None:
        duration = _number(args.duration, "--duration [s]", positive=True)
        rec = rec.slice_time(rec.t[0], rec.t[0] + duration * (1 + 1e-12))
    noise = _number(args.noise_std, "--noise-std", positive=True, allow_zero=True)
    seed = _seed(args.seed)
    if seed is not None and noise is None:
        raise InputError("--seed only seeds the measurement noise; give --noise-std as well.")
    inputs = {c: rec[c] for c in model.input_names}
    progress(f"physid simulate {args.model}: {model.n} nodes, {rec.n_samples} samples ...")
    out = simulate_structure(model, rec.t, inputs)
    if noise:
        rng = np.random.default_rng(seed)
        noisy = {c: out[c] + noise * rng.standard_normal(out.n_samples) for c in model.output_names}
        out = out.with_channels(noisy)
    print(save_recording(out, args.out))
    return 0
