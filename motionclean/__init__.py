"""motionclean: coordinate-invariant cleaning of motion-capture clips.

>>> import motionclean as mc
>>> m = mc.load("clip.bvh")          # Motion: skeleton + (F, J, 4) quaternions
>>> mc.save(m, "copy.bvh")           # identity round trip reproduces the file
>>> q = mc.lee_shin(m.rotations, mc.filters.masks.binomial(2))  # filters: arrays to arrays
>>> positions, rotations = mc.kinematics.forward(m)  # world space
"""

import sys as _sys

from . import filters
from .core import kinematics
from .core.errors import MotionError, UsageError
from .core.motion import Motion
from .core.version import __version__
from .filters import *  # noqa: F403 (the filter functions, filters.__all__)
from .io import load, save
from .steps.pipeline import Pipeline

# `motionclean.kinematics` is the public name of the world-space module (DESIGN's API):
# `import motionclean.kinematics` and `from motionclean.kinematics import forward` work too
_sys.modules[f"{__name__}.kinematics"] = kinematics

__all__ = [
    "Motion",
    "MotionError",
    "Pipeline",
    "UsageError",
    "__version__",
    "kinematics",
    "load",
    "save",
    *filters.__all__,
]
