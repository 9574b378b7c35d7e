"""User trials of paper 1 (section IV.A-B): course, colour-word task, plan, logs, analysis."""
