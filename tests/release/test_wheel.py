"""The wheel path of the Docker image, without an engine and without the network.

Given the wheel built from exactly what the Dockerfile's builder copies, installed (``--no-deps
--no-index``) into a fresh virtual environment outside the source tree, whose dependencies come
from this venv's site-packages through a ``.pth`` line (a plain path: that directory's own
``.pth`` files, among them the editable install's, are not processed, so nothing resolves to the
source tree), when the image's exact CMD starts from a directory outside the tree, then the
HEALTHCHECK's own command and a plain GET answer 200, a tab receives the AUV mesh read from the
installed package data, and SIGTERM ends the server with exit status 0 within 2 s.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import sysconfig
import time
import urllib.request
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import msgspec.msgpack
import numpy as np
import pytest
import zstandard

from app.figures.scene import auv_parts_body
from tests.release.dockerfile import REPO, exec_form, healthcheck
from tests.server.viser_client import CAMERA, connect_raw

pytestmark = pytest.mark.release

BUILDER_COPIES = ("pyproject.toml", "README.md", "tauvcore", "app")   # the Dockerfile's builder stage
EXIT_WITHIN_S = 2.0
START_TIMEOUT_S = 120.0


@dataclass(frozen=True)
class Installed:
    venv: Path          # the fresh virtual environment
    python: Path        # its interpreter
    site: Path          # its site-packages
    wheel: Path         # the wheel installed into it


def _free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _run(cmd: list[str], timeout_s: float = 300.0, **kwargs) -> subprocess.CompletedProcess:
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, check=False, **kwargs)
    assert result.returncode == 0, f"{cmd}:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return result


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Installed]:
    root = tmp_path_factory.mktemp("release")
    src = root / "src"                   # the builder's /src: only what it copies, no stale build/
    src.mkdir()
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc", "*.egg-info")
    for name in BUILDER_COPIES:
        if (REPO / name).is_dir():
            shutil.copytree(REPO / name, src / name, ignore=ignore)
        else:
            shutil.copy2(REPO / name, src / name)
    dist = root / "dist"
    t0 = time.monotonic()
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index",
          "--wheel-dir", str(dist), "."], cwd=src)
    wheels = list(dist.glob("tauv-*.whl"))
    assert len(wheels) == 1, wheels
    venv = root / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)])
    python = venv / "bin" / "python"
    # this venv's pip installs into the new one: the wheel alone, from the file, nothing fetched
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index",
          "--no-cache-dir", "--disable-pip-version-check", str(wheels[0])], cwd=root)
    site = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     cwd=root).stdout.strip())
    assert site.is_relative_to(venv), site
    # dependencies without the network: this venv's site-packages as a plain path, added after
    # the new venv's own (the wheel's app and tauvcore come first, the editable finder never runs)
    (site / "zz_tauv_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    print(f"wheel built and installed in {time.monotonic() - t0:.1f} s")
    yield Installed(venv=venv, python=python, site=site, wheel=wheels[0])


def test_wheel_ships_the_mesh_and_only_the_packages(installed: Installed) -> None:
    with zipfile.ZipFile(installed.wheel) as wheel:
        names = wheel.namelist()
        assert wheel.read("app/assets/auv.obj") == (REPO / "app" / "assets" / "auv.obj").read_bytes()
        scripts = sorted((REPO / "app" / "assets").glob("*.js"))     # the page scripts (app/dashboard/page_scripts.py)
        assert scripts and all(wheel.read(f"app/assets/{p.name}") == p.read_bytes() for p in scripts)
    tops = {n.split("/")[0] for n in names if not n.startswith("tauv-")}
    assert tops == {"app", "tauvcore"}, tops
    sources = {p.relative_to(REPO).as_posix() for top in tops for p in (REPO / top).rglob("*.py")
               if "__pycache__" not in p.parts}
    assert sources <= set(names), sorted(sources - set(names))     # every module, subpackages included
    assert not any("__pycache__" in n or n.endswith((".nbi", ".nbc")) for n in names)


def test_fresh_venv_imports_the_wheel_not_the_source_tree(installed: Installed, tmp_path: Path) -> None:
    code = ("import app, tauvcore, tauvcore.engine as r, app.figures.scene as s; print(app.__file__);"
            " print(*tauvcore.__path__); print(r.__file__); print(s.ASSETS_DIR);"
            " print((s.ASSETS_DIR / 'auv.obj').is_file());"
            " import app.dashboard.page_scripts as ps; print('localStorage.setItem' in ps.report([], 'p-', 'k'))")
    out = _run([str(installed.python), "-c", code], cwd=tmp_path).stdout.split()
    app_file, tauvcore_dir, runner_file, assets_dir, found, script = out    # tauvcore: a namespace package, one portion
    for path in (app_file, tauvcore_dir, runner_file, assets_dir):
        assert Path(path).is_relative_to(installed.site), out
        assert not Path(path).is_relative_to(REPO), out
    assert found == "True" and script == "True"


def _decode_batch(data: bytes) -> list[dict]:
    """Messages of one server batch, binary placeholders replaced by their bytes (viser 1.1:
    zstd msgpack, then the raw buffers, each 8-byte aligned: viser/infra/_infra.py)."""
    inner_size = int.from_bytes(data[:8], "little")
    compressed_size = int.from_bytes(data[8:16], "little")
    batch = msgspec.msgpack.decode(zstandard.ZstdDecompressor().decompress(
        data[16:16 + compressed_size], max_output_size=inner_size))
    buffers, offset = [], 16 + compressed_size
    for length in batch.get("binaryBufferLengths", ()):
        offset += (8 - offset % 8) % 8
        buffers.append(data[offset:offset + length])
        offset += length

    def resolve(value):
        if isinstance(value, dict):
            if "__binary_index" in value:
                return np.frombuffer(buffers[value["__binary_index"]], dtype=value["dtype"])
            return {k: resolve(v) for k, v in value.items()}
        if isinstance(value, list):
            return [resolve(v) for v in value]
        return value

    return [resolve(m) for m in batch["messages"]]


def _meshes_of_a_tab(url: str, names: set[str], timeout_s: float = 60.0) -> dict[str, dict]:
    """Connect as a page does and collect the MeshMessages named ``names``."""
    ws = connect_raw(url)
    found: dict[str, dict] = {}
    try:
        ws.send(msgspec.msgpack.encode(CAMERA))
        deadline = time.monotonic() + timeout_s
        while set(found) != names:
            remaining = deadline - time.monotonic()
            assert remaining > 0, f"meshes received: {sorted(found)}, wanted {sorted(names)}"
            for message in _decode_batch(ws.recv(timeout=remaining)):
                if message.get("type") == "MeshMessage" and message.get("name") in names:
                    found[message["name"]] = message["props"]
    finally:
        ws.close()
    return found


def test_image_cmd_serves_health_and_mesh_and_stops_on_sigterm(installed: Installed, tmp_path: Path) -> None:
    cmd = exec_form("CMD")
    _, health = healthcheck()
    port = 8080 if _free(8080) else _free_port()     # the image's port unless this machine uses it
    cmd = [str(port) if a == "8080" else a for a in cmd]
    health = [h.replace(":8080/", f":{port}/") for h in health]
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.update(PATH=f"{installed.venv / 'bin'}{os.pathsep}{env.get('PATH', '')}", PYTHONUNBUFFERED="1",
               VIRTUAL_ENV=str(installed.venv), PYTHONDONTWRITEBYTECODE="1")
    workdir = tmp_path / "run"                       # outside the source tree, as the image's WORKDIR
    workdir.mkdir()
    log_path = tmp_path / "server.log"
    assert shutil.which(cmd[0], path=env["PATH"]) == str(installed.venv / "bin" / cmd[0])
    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd, cwd=workdir, env=env, stdout=log, stderr=subprocess.STDOUT,
                                start_new_session=True)
    try:
        t0 = time.monotonic()
        while "tauv dashboard: http" not in log_path.read_text():
            assert proc.poll() is None, f"exited {proc.returncode}:\n{log_path.read_text()[-3000:]}"
            assert time.monotonic() - t0 < START_TIMEOUT_S, log_path.read_text()[-3000:]
            time.sleep(0.1)
        started_s = time.monotonic() - t0

        # the image's HEALTHCHECK, as the engine runs it (inside the container: the venv's python)
        check = subprocess.run(health, cwd=workdir, env=env, capture_output=True, text=True, timeout=30, check=False)
        assert check.returncode == 0, check.stdout + check.stderr
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=10) as response:
            assert response.status == 200
            assert "text/html" in response.headers.get("Content-Type", "")

        # the 3-D scene: the hull and four fins, as sent to a tab, are the installed auv.obj's
        names = {"/auv", *(f"/auv/fin{k}" for k in range(1, 5))}
        meshes = _meshes_of_a_tab(f"ws://127.0.0.1:{port}", names)
        (hull_v, hull_f), fins = auv_parts_body()        # read here from the source tree's app/assets
        np.testing.assert_allclose(meshes["/auv"]["vertices"].reshape(-1, 3), hull_v, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(meshes["/auv"]["faces"].reshape(-1, 3), hull_f)
        for k, fin in enumerate(fins, start=1):
            np.testing.assert_allclose(meshes[f"/auv/fin{k}"]["vertices"].reshape(-1, 3), fin.verts_hinge,
                                       rtol=0, atol=1e-6)

        # docker stop: SIGTERM to the CMD's process
        t1 = time.monotonic()
        os.kill(proc.pid, signal.SIGTERM)
        try:
            rc = proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            rc = None
        stopped_s = time.monotonic() - t1
        text = log_path.read_text()
        print(f"port {port}: started in {started_s:.1f} s, exit {rc} {stopped_s:.2f} s after SIGTERM")
        assert rc == 0, text[-3000:]
        assert stopped_s < EXIT_WITHIN_S, stopped_s
        assert "Traceback" not in text, text[-3000:]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)
        else:
            try:
                os.killpg(proc.pid, signal.SIGKILL)      # any worker left behind
            except ProcessLookupError:
                pass
