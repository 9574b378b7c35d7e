"""Slow, obvious versions of the arm core's computations, used only by tests.

The package holds one compiled implementation of each computation (``cobotsafety.arm``,
``cobotsafety.least_distance``); the modules here compute the same quantities the plainest way
(numpy loops, pinocchio's kinematics, quadprog's QP) so that a test can hold the compiled code
equal to them. Nothing in ``cobotsafety`` imports them.
"""
