"""Build a robot, evaluate its kinematics and dynamics, and load an arm from URDF.

Run: python examples/robot_model.py
"""

from __future__ import annotations

import numpy as np

import mmplan

robot = mmplan.get_robot("youbot-3r")
q0 = np.array([0.0, -0.5, np.pi / 2, 0.0, 0.0, 0.0, -0.17, 0.35])  # [PajakPajak]'s start
print(robot)
print("end effector k(q0) [m]:", np.round(robot.ee_position(q0), 4))
print("manipulability mu(q0):", round(robot.manipulability(q0), 5))
print("Pfaffian A(q0) N(q0) = 0:", np.allclose(robot.pfaffian(q0) @ robot.null_basis(q0), 0))
tau = robot.actuator_efforts(q0, np.zeros(robot.n), np.zeros(robot.n))
print(
    "efforts holding q0 at rest [N m]:", dict(zip(robot.actuators, np.round(tau, 3), strict=True))
)
print("torque limits [N m]:", robot.limits.torque_min, robot.limits.torque_max)
