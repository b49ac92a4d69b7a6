"""The package's exception hierarchy.

Errors are raised at boundaries (config, calibration, images, bags) with messages that name
the offending field, file, topic or shape. Numerical failures inside a frame are not
exceptions: they are a ``FitStatus`` in the optimizer's result.
"""
from __future__ import annotations


class HandTrackerError(Exception):
    """Base class of every error this package raises on purpose."""


class ConfigError(HandTrackerError, ValueError):
    """A configuration value is missing, of the wrong type or out of range."""


class ShapeError(HandTrackerError, ValueError):
    """An array has the wrong shape or dtype."""


class CalibrationError(HandTrackerError, ValueError):
    """Camera intrinsics/extrinsics are missing, inconsistent or invalid."""


class ImageFormatError(HandTrackerError, ValueError):
    """An image has an unsupported encoding, a wrong size or non-finite values."""


class BagFormatError(HandTrackerError):
    """A bag is missing, truncated, corrupt, or holds a type or topic we cannot use."""
