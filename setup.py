"""Package layout: cobotsafety/ plus app/ and assets/ mapped under cobotsafety."""

from setuptools import find_packages, setup

packages = find_packages(include=["cobotsafety", "cobotsafety.*"])
packages += ["cobotsafety.app"] + [f"cobotsafety.app.{p}" for p in find_packages("app")]
packages += ["cobotsafety.assets"]

setup(
    packages=packages,
    package_dir={"cobotsafety.app": "app", "cobotsafety.assets": "assets"},
)
