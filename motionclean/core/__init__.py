"""The model and the algebra: :class:`~motionclean.core.motion.Motion`, unit quaternions,
forward kinematics, up axis and body height, feet and ground contacts, rest-pose frames,
validation, errors and the thread helpers.

The bottom layer: it imports nothing else of the package.
"""
