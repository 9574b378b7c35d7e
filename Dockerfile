# cobotsafety demo in a container (runtime only: no tests, no browser).
#   docker build -t cobotsafety .
#   docker run --rm -p 127.0.0.1:8080:8080 cobotsafety
# Inside the container the demo listens on every interface (so the published port reaches it)
# and prints a token: a tab must enter it before it may change the robot or the scene.
# Publish beyond 127.0.0.1 only on a network you trust. Add --cap-add=SYS_NICE to let the
# control thread run under real-time scheduling.

# ---- build: dependencies first (a cached layer while only the source changes), then the package
FROM python:3.11-slim AS build
ENV PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_CACHE_DIR=1 PIP_ROOT_USER_ACTION=ignore
RUN python -m venv /opt/venv
ENV PATH=/opt/venv/bin:$PATH
WORKDIR /src
COPY pyproject.toml ./
# The runtime dependencies listed in pyproject.toml (no extras: no test, train or compare).
RUN python -c "import tomllib; print('\n'.join(tomllib.load(open('pyproject.toml', 'rb'))['project']['dependencies']))" \
        > /tmp/requirements.txt \
    && pip install -r /tmp/requirements.txt
COPY README.md ./
COPY cobotsafety ./cobotsafety
RUN pip install --no-deps . && rm -rf /src

# ---- runtime: the virtual environment, a user without privileges, the compiled kernels
FROM python:3.11-slim AS runtime
ENV DEBIAN_FRONTEND=noninteractive
# System libraries of the pinocchio/coal wheels and of trimesh/pycollada's mesh loading.
RUN apt-get update -qq \
    && apt-get install -y -qq --no-install-recommends libgl1 libglib2.0-0 \
    && rm -rf /var/lib/apt/lists/*
RUN useradd --create-home --uid 10001 cobot
COPY --from=build /opt/venv /opt/venv
ENV PATH=/opt/venv/bin:$PATH PYTHONUNBUFFERED=1 NUMBA_CACHE_DIR=/home/cobot/.cache/numba
USER cobot
WORKDIR /home/cobot
# Compile and cache the numba kernels now, as the user who runs the demo (the first start would
# otherwise spend ~40 s on it): build the demo headless, step and draw the planar arm and a 3D arm.
RUN python -c "from cobotsafety.app.demo_app import DemoApp, DemoConfig; \
app = DemoApp(DemoConfig(port=0)); app.loop.step_once(); app.render_once(); \
app.switch_scene('panda'); app.replay.seek(5.0); app.loop.step_once(); app.render_once(); app.stop()"

EXPOSE 8080
HEALTHCHECK --interval=30s --timeout=5s --start-period=120s --retries=3 \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8080/', timeout=4)"
CMD ["cobotsafety", "demo", "--host", "0.0.0.0", "--port", "8080"]
