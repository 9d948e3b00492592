"""motionclean: coordinate-invariant cleaning of motion-capture clips.

>>> import motionclean as mc
>>> m = mc.load("clip.bvh")          # Motion: skeleton + (F, J, 4) quaternions
>>> mc.save(m, "copy.bvh")           # identity round trip reproduces the file
"""

from .core.errors import MotionError, UsageError
from .core.motion import Motion
from .core.version import __version__
from .io import load, save
from .steps.pipeline import Pipeline

__all__ = ["Motion", "MotionError", "Pipeline", "UsageError", "__version__", "load", "save"]
