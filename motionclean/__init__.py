"""motionclean: coordinate-invariant cleaning of motion-capture clips.

>>> import motionclean as mc
>>> m = mc.load("clip.bvh")          # Motion: skeleton + (F, J, 4) quaternions
>>> mc.save(m, "copy.bvh")           # identity round trip reproduces the file
"""

__version__ = "0.1.0"

from .errors import MotionError, UsageError
from .io import load, save
from .motion import Motion
from .pipeline import Pipeline

__all__ = ["Motion", "MotionError", "Pipeline", "UsageError", "__version__", "load", "save"]
