"""The browser demo (viser): a robot, the human capsules of a replay and a gizmo to drag.

Data flows one way: replay -> human capsules -> limitations -> filter -> integrator -> scene.
The app only wires the pieces together: ``control_loop`` steps a ``Teleoperated`` robot at a
fixed rate, ``demo_app`` renders it at its own rate and routes the browser's inputs to the loop.
"""
