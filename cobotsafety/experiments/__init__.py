"""Headless experiments behind ``cobotsafety experiment``: one module per experiment."""
