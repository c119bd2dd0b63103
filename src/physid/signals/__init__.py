"""Recordings, file I/O, excitation signals and measurement noise."""

from .io import load_recording, save_recording
from .recording import Recording

__all__ = ["Recording", "load_recording", "save_recording"]
