"""A moving body's inertia and joints, and the joints' names, by which every later layer reads
a vehicle's motion: <body>_lateral and <body>_yaw (docs/frames.md), and a spatial body's
<body>_vertical, <body>_roll and <body>_pitch (docs/spatial.md).
"""

from __future__ import annotations

import mujoco

from rail_mj.layout import Suspension
from rail_mj.vehicle.rounding import _g6

# A wheelset's lateral/yaw joints are named <body>_lateral and <body>_yaw.
LATERAL, YAW = "lateral", "yaw"
# A spatial vehicle's car body and bogie frames also move vertically, roll and pitch
# (docs/spatial.md): joints <body>_vertical, <body>_roll, <body>_pitch.
VERTICAL, ROLL, PITCH = "vertical", "roll", "pitch"
SPATIAL_BODY = (LATERAL, YAW, VERTICAL, ROLL, PITCH)
SPATIAL_WHEELSET = (LATERAL, YAW)  # vertical and roll held by the (rigid) track


def _add_planar_joints(body, suspension: Suspension | None) -> None:
    """Lateral slide and yaw hinge; `suspension` (None: free) is their stiffness and damping."""
    s = suspension or Suspension(0.0, 0.0)
    body.add_joint(
        name=f"{body.name}_{LATERAL}",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[0, 1, 0],
        stiffness=_g6(s.lateral_stiffness, 0.0, 0.0),
        damping=_g6(s.lateral_damping, 0.0, 0.0),
    )
    body.add_joint(
        name=f"{body.name}_{YAW}",
        type=mujoco.mjtJoint.mjJNT_HINGE,
        axis=[0, 0, 1],
        stiffness=_g6(s.yaw_stiffness, 0.0, 0.0),
        damping=_g6(s.yaw_damping, 0.0, 0.0),
    )


def _add_spatial_joints(body) -> None:
    """Lateral slide and yaw hinge (as a planar body's), then vertical slide, roll and pitch
    hinges, all at the centre of mass and with no spring: absolute coordinates."""
    _add_planar_joints(body, None)
    body.add_joint(name=f"{body.name}_{VERTICAL}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
    body.add_joint(name=f"{body.name}_{ROLL}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0])
    body.add_joint(name=f"{body.name}_{PITCH}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])


def _set_inertia(body, mass: float, inertia) -> None:
    body.explicitinertial = True
    # Centre of mass at the body origin, principal axes along the track axes; set
    # explicitly because an unset ipos is not the origin.
    body.ipos = [0.0, 0.0, 0.0]
    body.iquat = [1.0, 0.0, 0.0, 0.0]
    body.mass = _g6(mass)[0]
    body.inertia = _g6(*inertia)
