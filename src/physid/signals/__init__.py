"""Recordings, file I/O, excitation signals and measurement noise."""

from .recording import Recording

__all__ = ["Recording"]
