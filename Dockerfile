# cobotsafety demo in a container: mirrors .ci/run's install steps, then serves the browser demo.
#   docker build -t cobotsafety . && docker run --rm -p 8080:8080 cobotsafety
FROM python:3.11-slim

ENV DEBIAN_FRONTEND=noninteractive PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore \
    PYTHONUNBUFFERED=1
# System needs of pinocchio/coal wheels, trimesh/pycollada meshes and the headless browser tests.
RUN apt-get update -qq \
    && apt-get install -y -qq --no-install-recommends libgl1 libglib2.0-0 chromium \
    && rm -rf /var/lib/apt/lists/*

WORKDIR /opt/cobotsafety
COPY . .
RUN python3 -m pip install -q -e ".[test]"
# Compile and cache the numba kernels (capsule distance, arm mapping) now, not at first start.
RUN python3 -c "import numpy as np; from cobotsafety.control.human_aware import HumanAwareTeleop; \
HumanAwareTeleop().step(np.zeros(3), 0.002)"

EXPOSE 8080
CMD ["cobotsafety", "demo", "--host", "0.0.0.0", "--port", "8080"]
