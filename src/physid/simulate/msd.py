"""The mass-spring-damper (MSD) of Oueslati et al. (2011), simulated exactly.

The model is the normalised equation (the paper's eq. 1/22)::

    ẍ + θ1 ẋ + θ2 x = u,   θ1 = c/m = 2 ζ ω0,   θ2 = k/m = ω0²,   u = F/m  [m/s²]

Input amplitude: the paper's section 5 says "A1 is set to 333.3333 N" but puts A1 on the
right-hand side of the *normalised* equation (22), ``u = A1 sin(ω1 t)``. physid follows eq. (22):
``amplitude`` is the amplitude of u = F/m in m/s², and A1 = 1000/3 m/s² is a force of 1000 N on
the 3 kg mass. Give ``force_amplitude`` [N] (with the mass) to state a force instead.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .._resources import check_memory
from .._validate import as_1d, check_in_range, check_positive
from ..errors import InputError, arg
from ..signals.excitation import Multisine, Sinusoid
from .linear import simulate_linear_ode
from .recordings import LinearODERecording

__all__ = [
    "PAPER_MSD",
    "MSDParameters",
    "msd_parameters",
    "simulate_msd",
    "msd_paper_scenario",
]

#: The paper's system and experiment (Oueslati et al. 2011, section 5).
PAPER_MSD: dict[str, float] = {
    "mass": 3.0,  # [kg]
    "damping": 0.05,  # [N·s/m]
    "stiffness": 400.0,  # [N/m]
    "dt": 1e-3,  # [s]
    "duration": 5.0,  # [s]
    "amplitude": 1000.0 / 3.0,  # A1 [m/s²] on the normalised equation (= 1000 N / 3 kg)
    "disturbance_amplitude": 0.1,  # A2 [m]
    "disturbance_ratio": 500.0,  # ω2 / ω0
}


#: Peak memory of `simulate_msd` per sample [bytes]: measured about 180 for a clean run and 230
#: with noise and a disturbance (time grid, input, states, the recursion's work arrays).
BYTES_PER_SAMPLE = 240

#: Largest rate × sample period simulated [rad per sample]: a system (or input) that turns more
#: than 1e6 rad between two samples lies some 300 000 times above the Nyquist frequency, and the
#: matrix exponential of one step loses its phase to rounding and then overflows.
MAX_PHASE_STEP = 1e6


class MSDParameters(dict):
    """θ1 [1/s], θ2 [1/s²], b0 and, when known, mass [kg] (a plain dict with a helper)."""

    @property
    def natural_frequency(self) -> float:
        """ω0 = √θ2 [rad/s]."""
        return float(np.sqrt(self["theta2"]))

    @property
    def damping_ratio(self) -> float:
        """ζ = θ1 / (2 ω0)."""
        return float(self["theta1"] / (2.0 * np.sqrt(self["theta2"])))


def msd_parameters(
    *,
    mass: float | None = None,
    damping: float | None = None,
    stiffness: float | None = None,
    natural_frequency: float | None = None,
    damping_ratio: float | None = None,
) -> MSDParameters:
    """θ1, θ2 (and the mass when given) from (m, c, k) or from (ω0, ζ).

    Parameters
    ----------
    mass : float [kg]
    damping : float [N·s/m]
    stiffness : float [N/m]
    natural_frequency : float [rad/s]
        ω0, instead of (c, k); the mass is then optional (needed only for force inputs).
    damping_ratio : float
        ζ >= 0, with ``natural_frequency``.

    Returns
    -------
    MSDParameters
        ``{"theta1": c/m, "theta2": k/m, "b0": 1.0, "mass": m or None}``.

    Examples
    --------
    >>> p = msd_parameters(mass=3.0, damping=0.05, stiffness=400.0)
    >>> round(p.natural_frequency, 6), round(p.damping_ratio, 6)
    (11.547005, 0.000722)
    """
    physical = damping is not None or stiffness is not None
    modal = natural_frequency is not None or damping_ratio is not None
    if physical and modal:
        raise InputError(
            "describe the MSD either by damping and stiffness (with the mass) or by "
            "natural_frequency "
            "and damping_ratio, not by both."
        )
    m = None if mass is None else check_positive(mass, "mass [kg]")
    if physical:
        if m is None or damping is None or stiffness is None:
            raise InputError(
                "the physical description needs mass [kg], damping [N·s/m] and stiffness "
                "[N/m]; got "
                f"mass={mass!r}, damping={damping!r}, stiffness={stiffness!r}."
            )
        c = check_positive(damping, "damping [N·s/m]", allow_zero=True)
        k = check_positive(stiffness, "stiffness [N/m]")
        return MSDParameters(theta1=c / m, theta2=k / m, b0=1.0, mass=m)
    if natural_frequency is None or damping_ratio is None:
        raise InputError(
            "give mass, damping and stiffness, or natural_frequency [rad/s] and damping_ratio; got "
            f"natural_frequency={natural_frequency!r}, damping_ratio={damping_ratio!r}."
        )
    w0 = check_positive(natural_frequency, "natural_frequency [rad/s]")
    zeta = check_positive(damping_ratio, "damping_ratio", allow_zero=True)
    return MSDParameters(theta1=2.0 * zeta * w0, theta2=w0 * w0, b0=1.0, mass=m)


def _apply_jump(current: MSDParameters, change, when: float) -> MSDParameters:
    """New θ after a jump. A number is a new stiffness [N/m] (c and m unchanged)."""
    if not isinstance(change, Mapping):
        try:
            change = {"stiffness": float(change)}
        except (TypeError, ValueError):
            raise InputError(
                f"the jump at t = {when} s must be a new stiffness [N/m] or a mapping; got "
                f"{change!r}."
            ) from None
    allowed = {"stiffness", "damping", "natural_frequency", "damping_ratio", "theta1", "theta2"}
    unknown = sorted(set(change) - allowed)
    if unknown:
        raise InputError(
            f"the jump at t = {when} s changes {unknown}; allowed: {sorted(allowed)} (the "
            "mass cannot "
            "jump: it would also change the normalised input u = F/m)."
        )
    out = MSDParameters(current)
    m = out.get("mass")
    for key in ("stiffness", "damping"):
        if key in change and m is None:
            raise InputError(
                f"the jump at t = {when} s sets the {key}, which needs the mass; give "
                f"{arg('mass', '...', cli='KG')} "
                "(or jump natural_frequency / theta2 instead)."
            )
    if "stiffness" in change:
        out["theta2"] = (
            check_positive(change["stiffness"], f"stiffness of the jump at t = {when} s") / m
        )
    if "damping" in change:
        out["theta1"] = (
            check_positive(
                change["damping"], f"damping of the jump at t = {when} s", allow_zero=True
            )
            / m
        )
    if "natural_frequency" in change:  # a spring change: θ1 = c/m is kept
        out["theta2"] = (
            check_positive(change["natural_frequency"], "natural_frequency of the jump") ** 2
        )
    if "damping_ratio" in change:  # ω0 is kept
        zeta = check_positive(change["damping_ratio"], "damping_ratio of the jump", allow_zero=True)
        out["theta1"] = 2.0 * zeta * np.sqrt(out["theta2"])
    if "theta1" in change:
        out["theta1"] = check_positive(change["theta1"], "theta1 of the jump", allow_zero=True)
    if "theta2" in change:
        out["theta2"] = check_positive(change["theta2"], "theta2 of the jump")
    return out


def _check_size(t, duration, dt) -> float | None:
    """Refuse a time grid whose simulation needs more than half the available memory.

    Returns the sample period (the largest step of ``t``), or None when the grid is not given
    in a form that can be checked here (`simulate_linear_ode` then reports it).
    """
    if t is not None:
        steps = np.diff(np.asarray(t, dtype=float).ravel())
        return float(steps.max()) if steps.size and np.all(np.isfinite(steps)) else None
    try:
        duration, dt = float(duration), float(dt)
    except (TypeError, ValueError):
        return None
    if not (np.isfinite(duration) and np.isfinite(dt) and duration > 0 and dt > 0):
        return None
    samples = duration / dt + 1.0  # a float: no overflow however small dt is
    check_memory(
        samples * BYTES_PER_SAMPLE,
        what=(
            f"simulating {arg('duration', repr(duration), cli=f'{duration:g}')} s at "
            f"{arg('dt', repr(dt), cli=f'{dt:g}')} s ({samples:.3g} samples)"
        ),
        fix=f"raise {arg('dt')} or shorten {arg('duration')}",
    )
    return dt


_SYSTEM_FIX = (
    f"check {arg('stiffness')}, {arg('damping')} and {arg('mass')} (or "
    f"{arg('natural_frequency')}), or lower {arg('dt')}"
)


def _check_rates(segment: MSDParameters, dt: float | None, where: str, fix: str) -> None:
    """Refuse a system whose ω0 or θ1 = c/m is not finite or turns > 1e6 rad per sample."""
    for name, unit, value in (
        ("natural frequency ω0 = √(k/m)", "rad/s", np.sqrt(segment["theta2"])),
        ("damping rate θ1 = c/m", "1/s", segment["theta1"]),
    ):
        if not np.isfinite(value):
            raise InputError(f"{where}: the {name} is not finite ({value}); {fix}.")
        if dt is not None and value * dt > MAX_PHASE_STEP:
            raise InputError(
                f"{where}: the {name} is {value:.3g} {unit}, {value * dt:.3g} per sample at "
                f"{arg('dt', repr(dt), cli=f'{dt:g}')} s; at most 1e6 per sample (a system that "
                f"fast cannot be sampled meaningfully at that period); {fix}."
            )


def simulate_msd(
    *,
    mass: float | None = None,
    damping: float | None = None,
    stiffness: float | None = None,
    natural_frequency: float | None = None,
    damping_ratio: float | None = None,
    amplitude: float | None = None,
    force_amplitude: float | None = None,
    angular_frequency: float | None = None,
    ratio: float | None = None,
    phase: float | None = None,
    input=None,  # noqa: A002
    hold: str = "foh",
    t=None,
    duration: float | None = None,
    dt: float | None = None,
    x0=(0.0, 0.0),
    jumps: Sequence[tuple[float, Any]] | None = None,
    snr_db: float | None = None,
    noise_std: float | None = None,
    disturbance: tuple[float, float] | None = None,
    rng=None,
    output_derivatives: bool = False,
) -> LinearODERecording:
    """Simulate ``ẍ + θ1 ẋ + θ2 x = u`` exactly for ``u = amplitude · sin(ω t + phase)``.

    Parameters
    ----------
    mass, damping, stiffness : float [kg], [N·s/m], [N/m]
        The physical description; or
    natural_frequency, damping_ratio : float [rad/s], [-]
        ω0 and ζ (``mass`` optional, needed for ``force_amplitude`` or stiffness jumps).
    amplitude : float [m/s²]
        Amplitude of the normalised input u = F/m (the paper's A1 = 1000/3). Exactly one of
        ``amplitude``, ``force_amplitude`` and ``input``.
    force_amplitude : float [N]
        Amplitude of the force F; u = F/m (needs ``mass``).
    angular_frequency : float [rad/s]
        ω1 of the sinusoid; or give
    ratio : float
        Z = ω1 / ω0 (ω0 of the initial parameters).
    phase : float [rad], optional
        Phase of the built-in sinusoid (default 0). Not allowed with ``input`` (put the phase
        into the `Sinusoid` instead).
    input : Sinusoid, Multisine, callable or array, optional
        Any other input u [m/s²] (see `simulate_linear_ode`), instead of amplitude/frequency.
    t, duration, dt : time grid (default: the paper's 5 s at Δ = 1 ms)
    x0 : (x0 [m], v0 [m/s])
    jumps : sequence of (time [s], change)
        A number is a new stiffness [N/m] (c, m unchanged); a mapping may set ``stiffness``,
        ``damping``, ``natural_frequency`` (keeps θ1), ``damping_ratio`` (keeps ω0), ``theta1``,
        ``theta2``. Position and velocity stay continuous.
    snr_db, noise_std, disturbance, rng, output_derivatives
        See `simulate_linear_ode`.

    Returns
    -------
    Recording
        ``u`` [m/s²], ``x`` [m] (measured), ``x_true`` [m] when noise/disturbance was added.
        Metadata holds m, θ1, θ2, ω0, ζ, the input and the noise settings.
    """
    params = msd_parameters(
        mass=mass,
        damping=damping,
        stiffness=stiffness,
        natural_frequency=natural_frequency,
        damping_ratio=damping_ratio,
    )
    if t is None and duration is None and dt is None:
        duration, dt = PAPER_MSD["duration"], PAPER_MSD["dt"]
    step = _check_size(t, duration, dt)  # before anything of the grid's size is allocated
    _check_rates(params, step, "the system", _SYSTEM_FIX)
    meta: dict[str, Any] = {"model": "msd", "equation": "x'' + theta1 x' + theta2 x = u, u = F/m"}
    input = _msd_input(
        params, step, meta, amplitude, force_amplitude, angular_frequency, ratio, phase, input
    )
    x0 = as_1d(x0, "x0")
    segments, jump_list = _msd_segments(params, jumps, step)
    model = ([params["theta2"], params["theta1"], 1.0], [params["b0"]])
    meta.update(_msd_metadata(params, segments, jump_list))
    return simulate_linear_ode(
        model,
        t,
        duration=duration,
        dt=dt,
        input=input,
        hold=hold,
        x0=x0,
        jumps=jump_list or None,
        snr_db=snr_db,
        noise_std=noise_std,
        disturbance=disturbance,
        rng=rng,
        output_derivatives=output_derivatives,
        units={"u": "m/s^2", "x": "m"},
        metadata=meta,
    )


def _msd_input(
    params, step, meta, amplitude, force_amplitude, angular_frequency, ratio, phase, input
):
    """The input u of `simulate_msd`: the built-in sinusoid from its settings, or ``input``.

    Checks that exactly one input is given and that the sinusoid can be sampled at ``step``;
    records the input's settings in ``meta`` (updated in place: it is the caller's new dict).
    """
    w0 = params.natural_frequency
    given = [
        name
        for name, v in (
            ("amplitude", amplitude),
            ("force_amplitude", force_amplitude),
            ("input", input),
        )
        if v is not None
    ]
    if len(given) != 1:
        raise InputError(
            "give exactly one of amplitude (of u = F/m, m/s²), force_amplitude (N, with mass) and "
            f"input (any u); got {given or 'none'}."
        )
    if input is None:
        if (angular_frequency is None) == (ratio is None):
            raise InputError(
                "give exactly one of angular_frequency (ω1, rad/s) and ratio (Z = ω1/ω0); got "
                f"angular_frequency={angular_frequency!r}, ratio={ratio!r}."
            )
        if ratio is not None:
            omega1 = check_positive(ratio, "ratio", allow_zero=True) * w0
        else:
            omega1 = check_positive(angular_frequency, "angular_frequency [rad/s]", allow_zero=True)
        if force_amplitude is not None:
            if params["mass"] is None:
                raise InputError(
                    f"{arg('force_amplitude')} [N] needs the mass to form u = F/m; give "
                    f"{arg('mass', '...', cli='KG')} or give the amplitude of u directly "
                    f"({arg('amplitude', '...', cli='A')})."
                )
            amp = float(force_amplitude) / params["mass"]
            meta["force_amplitude"] = float(force_amplitude)
        else:
            amp = float(amplitude)
        if not np.isfinite(amp):
            raise InputError(f"the input amplitude must be finite; got {amp!r}.")
        if step is not None and not omega1 * step <= MAX_PHASE_STEP:
            what = f"{arg('ratio')} (ω1 = Z ω0)" if ratio is not None else arg("angular_frequency")
            raise InputError(
                f"the input's angular frequency ω1 = {omega1:.3g} rad/s is {omega1 * step:.3g} "
                f"rad per sample at {arg('dt', repr(step), cli=f'{step:g}')} s; at most 1e6 per "
                f"sample (far above the Nyquist frequency); lower {what}."
            )
        phase = 0.0 if phase is None else float(phase)
        input = Sinusoid(amp, omega1, phase)
        meta.update(
            {"amplitude": amp, "angular_frequency": omega1, "ratio": omega1 / w0, "phase": phase}
        )
    elif angular_frequency is not None or ratio is not None:
        raise InputError(
            "angular_frequency/ratio apply to the built-in sinusoid; omit them with input=..."
        )
    elif phase is not None:
        raise InputError(
            f"phase={phase!r} applies only to the built-in sinusoid (amplitude=/force_amplitude=); "
            "with input=... it would be ignored: drop phase, or pass Sinusoid(amplitude, omega, "
            "phase) as input."
        )
    elif isinstance(input, (Sinusoid, Multisine)):
        meta["input"] = repr(input)

    return input


def _msd_segments(params, jumps, step):
    """The parameter segments of `simulate_msd` (the initial one, then one per jump, in time
    order, each checked against the sample period) and the jumps as ``simulate_linear_ode``
    takes them."""
    segments = [params]
    jump_list = []
    for item in sorted(jumps or (), key=lambda j: float(j[0])):
        try:
            when, change = item
        except (TypeError, ValueError):
            raise InputError(
                f"each jump must be a pair (time [s], change); got {item!r}."
            ) from None
        nxt = _apply_jump(segments[-1], change, float(when))
        _check_rates(
            nxt, step, f"the jump at t = {float(when):g} s", f"check its value in {arg('jumps')}"
        )
        segments.append(nxt)
        jump_list.append((float(when), ([nxt["theta2"], nxt["theta1"], 1.0], [1.0])))
    return segments, jump_list


def _msd_metadata(params, segments, jump_list) -> dict[str, Any]:
    """The physical parameters of `simulate_msd`'s run and of every jump, for the metadata."""
    meta = {
        "mass": params["mass"],
        "theta1": params["theta1"],
        "theta2": params["theta2"],
        "natural_frequency": params.natural_frequency,
        "damping_ratio": params.damping_ratio,
        "jumps": [
            {
                "time": when,
                "theta1": s["theta1"],
                "theta2": s["theta2"],
                "natural_frequency": s.natural_frequency,
            }
            for (when, _), s in zip(jump_list, segments[1:], strict=True)
        ],
    }
    if params["mass"] is not None:
        meta["damping"] = params["theta1"] * params["mass"]
        meta["stiffness"] = params["theta2"] * params["mass"]
    return meta


def msd_paper_scenario(
    ratio: float = 1.0,
    snr_db: float | None = None,
    *,
    duration: float = PAPER_MSD["duration"],
    dt: float = PAPER_MSD["dt"],
    amplitude: float | None = None,
    force_amplitude: float | None = None,
    disturbance: tuple[float, float] | str | None = None,
    jumps: Sequence[tuple[float, Any]] | None = None,
    seed=None,
    mass: float = PAPER_MSD["mass"],
    damping: float | None = None,
    stiffness: float | None = None,
    natural_frequency: float | None = None,
    damping_ratio: float | None = None,
    x0=(0.0, 0.0),
) -> LinearODERecording:
    """The MSD experiment of Oueslati et al. (2011), section 5, ready-made.

    k = 400 N/m, c = 0.05 N·s/m, m = 3 kg (ω0 = 11.547 rad/s, ζ = 7.2e-4), T_s = 1 ms, 5 s,
    ``u = A1 sin(Z ω0 t)`` with A1 = 1000/3 m/s² (the paper's "333.3333 N" on the normalised
    equation, i.e. 1000 N / 3 kg; see the module docstring).

    Parameters
    ----------
    ratio : float
        Z = ω1 / ω0 (the paper uses 1 for Kalman-Bucy and 10 for the algebraic method).
    snr_db : float [dB], optional
        White noise on x at this SNR (the paper: 25, 50, 80 dB); ``None`` for clean data.
    duration, dt : float [s]
    amplitude : float [m/s²], optional
        A1 on the normalised equation (default 1000/3). Or ``force_amplitude`` [N] (u = F/m).
    disturbance : (A2 [m], ω2 [rad/s]) or "paper", optional
        ``"paper"`` is A2 = 0.1 m, ω2 = 500 ω0 (section 5.B), which aliases at 1 kHz sampling.
    jumps : sequence of (time [s], change), optional
        Parameter jumps (section 5.C, Fig. 16); a number is a new stiffness [N/m].
    seed : None, int, SeedSequence or Generator
        Noise seed; the same seed gives the same bits.
    mass, damping, stiffness, natural_frequency, damping_ratio : overrides of the paper's system.
    x0 : (x0 [m], v0 [m/s])

    Returns
    -------
    Recording
        t, u, x, and x_true when noise or a disturbance was added.
    """
    check_in_range(ratio, "ratio", 0.0, np.inf, high_open=True)
    if natural_frequency is not None or damping_ratio is not None:
        if damping is not None or stiffness is not None:
            raise InputError(
                "override either (damping, stiffness) or (natural_frequency, damping_ratio)."
            )
        base = msd_parameters(
            mass=mass, damping=PAPER_MSD["damping"], stiffness=PAPER_MSD["stiffness"]
        )
        system = {
            "natural_frequency": base.natural_frequency
            if natural_frequency is None
            else natural_frequency,
            "damping_ratio": base.damping_ratio if damping_ratio is None else damping_ratio,
            "mass": mass,
        }
    else:
        system = {
            "mass": mass,
            "damping": PAPER_MSD["damping"] if damping is None else damping,
            "stiffness": PAPER_MSD["stiffness"] if stiffness is None else stiffness,
        }
    w0 = msd_parameters(**system).natural_frequency
    if disturbance == "paper":
        disturbance = (PAPER_MSD["disturbance_amplitude"], PAPER_MSD["disturbance_ratio"] * w0)
    elif isinstance(disturbance, str):
        raise InputError(f"disturbance must be (A2, ω2), 'paper' or None; got {disturbance!r}.")
    if amplitude is None and force_amplitude is None:
        amplitude = PAPER_MSD["amplitude"]
    rec = simulate_msd(
        **system,
        amplitude=amplitude,
        force_amplitude=force_amplitude,
        ratio=ratio,
        duration=duration,
        dt=dt,
        x0=x0,
        jumps=jumps,
        snr_db=snr_db,
        disturbance=disturbance,
        rng=seed,
    )
    return rec
