# The tauv dashboard, headless, as a non-root user under tini.
#   docker build -t tauv .
#   docker run --rm -p 8080:8080 --name tauv tauv      # http://localhost:8080
#   docker inspect --format '{{.State.Health.Status}}' tauv
#   docker stop tauv                                    # SIGTERM: exits 0 within 2 s
# Nothing is fetched at run time: the viser client, plotly.js and the AUV mesh ship in the wheel.
# Tested without an engine by tests/release/ (hadolint; the wheel installed outside the tree and
# this CMD started, asked for its health, and stopped with SIGTERM).

# ---- builder: the package as a wheel (never an editable install) -------------------------------
FROM python:3.11-slim-bookworm AS builder
WORKDIR /src
# The build-system's requirements, pinned, so the build is the same every time.
RUN pip install --no-cache-dir setuptools==84.2.1 wheel==0.48.0
COPY pyproject.toml README.md ./
COPY tauvcore ./tauvcore
COPY app ./app
RUN pip wheel --no-cache-dir --no-deps --no-build-isolation --wheel-dir /dist .

# ---- runtime ------------------------------------------------------------------------------------
FROM python:3.11-slim-bookworm
# tini as PID 1: forwards docker stop's SIGTERM and reaps orphans (the server also handles
# SIGTERM as PID 1 itself: tests/server/test_signals.py).
RUN apt-get update \
    && apt-get install -y --no-install-recommends "tini=0.19.0-*" \
    && apt-get clean \
    && rm -rf /var/lib/apt/lists/*
ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    NUMBA_CACHE_DIR=/home/tauv/.cache/numba
# Dependencies pinned by the lock (regenerate: see its header), then the wheel alone.
COPY requirements.lock /tmp/requirements.lock
RUN pip install --no-cache-dir --require-hashes -r /tmp/requirements.lock
COPY --from=builder /dist/*.whl /tmp/dist/
RUN pip install --no-cache-dir --no-deps /tmp/dist/*.whl \
    && rm -rf /tmp/dist /tmp/requirements.lock \
    && useradd --uid 10001 --user-group --create-home --shell /usr/sbin/nologin tauv
USER 10001:10001
WORKDIR /home/tauv
# Compile the filter bank's kernels once, into the user's numba cache (else the first run pays ~20 s).
RUN python -m tauvcore.engine.warmup
EXPOSE 8080
HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import sys, urllib.request; sys.exit(urllib.request.urlopen('http://127.0.0.1:8080/', timeout=4).status != 200)"]
ENTRYPOINT ["/usr/bin/tini", "--"]
CMD ["tauv", "serve", "--host", "0.0.0.0", "--port", "8080"]
