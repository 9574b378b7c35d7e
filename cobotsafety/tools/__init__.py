"""Offline tools: training, evaluation, recording generation, capsule fitting, invariant and
validation campaigns. Runtime code never imports this package."""
