"""Benchmarks behind ``cobotsafety bench``: one module per measured pipeline."""
