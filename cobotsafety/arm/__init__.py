"""Paper 1's sliding filter on real 3D arms (pinocchio models from example-robot-data)."""
