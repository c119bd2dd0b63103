"""Recordings, file I/O, excitation signals and measurement noise."""

from .excitation import Multisine, Sinusoid, delayed_steps, multisine, schroeder_phases, sinusoid
from .io import load_recording, save_recording
from .join import JoinedRun, join_recordings
from .noise import (
    add_white_noise,
    alias_frequency,
    make_rng,
    noise_std_for_snr,
    sinusoidal_disturbance,
    snr_db,
)
from .recording import Recording

__all__ = [
    "Recording",
    "load_recording",
    "save_recording",
    "join_recordings",
    "JoinedRun",
    "add_white_noise",
    "noise_std_for_snr",
    "snr_db",
    "sinusoidal_disturbance",
    "alias_frequency",
    "make_rng",
    "Sinusoid",
    "Multisine",
    "sinusoid",
    "multisine",
    "schroeder_phases",
    "delayed_steps",
]
