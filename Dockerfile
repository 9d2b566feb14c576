# One image for the API and every worker (docker-compose.yml picks the command).
# Stage 1 builds the web UI into backend/alcove/static; stage 2 installs alcove.

FROM node:20-bookworm-slim AS frontend
WORKDIR /src/frontend
COPY frontend/package.json frontend/package-lock.json ./
RUN npm ci --no-audit --no-fund
COPY frontend/ ./
RUN npm run build

FROM python:3.11-slim-bookworm
ENV PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    ALCOVE_DATA_DIR=/data \
    ALCOVE_API_HOST=0.0.0.0 \
    ALCOVE_MIGRATIONS_DIR=/app/migrations
WORKDIR /app
# calculix-ccx: the solver of the fe-headrest-3d-ccx oracle (ccx on PATH)
RUN apt-get update && apt-get install -y --no-install-recommends calculix-ccx \
    && rm -rf /var/lib/apt/lists/*
# CPU build of torch (the pinned version in pyproject.toml)
RUN pip install --index-url https://download.pytorch.org/whl/cpu torch==2.13.0
COPY pyproject.toml README.md alembic.ini ./
COPY backend/ backend/
COPY worker/ worker/
COPY migrations/ migrations/
COPY --from=frontend /src/backend/alcove/static/ backend/alcove/static/
RUN pip install -e . && useradd --create-home --uid 1000 alcove && mkdir -p /data && chown alcove /data
USER alcove
VOLUME ["/data"]
EXPOSE 8000
HEALTHCHECK --interval=15s --timeout=5s --retries=5 CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/api/v1/health', timeout=3)"]
# `alcove up` = migrations + API + a worker on all queues; compose overrides per service
CMD ["alcove", "up"]
