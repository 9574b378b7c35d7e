"""Paper 1's planar RR arm: kinematics, limitations A-G, baselines and stepping."""
