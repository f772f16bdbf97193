# The tauv dashboard, headless. Build: docker build -t tauv .   Run: docker run -p 8080:8080 tauv
# Nothing is fetched at run time: the viser client, plotly.js and the meshes ship in the image.
FROM python:3.11-slim
WORKDIR /opt/tauv
COPY pyproject.toml README.md ./
COPY tauvcore ./tauvcore
COPY app ./app
COPY assets ./assets
RUN pip install --no-cache-dir -e . && useradd --create-home tauv
USER tauv
EXPOSE 8080
CMD ["tauv", "serve", "--host", "0.0.0.0", "--port", "8080"]
