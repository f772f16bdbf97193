"""The Docker page's sequence with a real container engine: podman with runc, no registry.

No image registry is reachable from our machines, so the Dockerfile's base image
(``python:3.11-slim-bookworm``) is replaced by a stand-in made from Debian's own packages:
``debootstrap --variant=minbase`` of bookworm with Debian's Python 3.11 and pip, ``python`` and
``pip`` linked into ``/usr/local/bin`` as in the official image, imported under the base's exact
name. The project's Dockerfile is then built unchanged, with ``--pull=never`` so nothing is
fetched from a registry, and ``--format docker`` (podman's default OCI format has no
``HEALTHCHECK``: it is dropped with a warning).

What the stand-in cannot prove: that the official image builds the Dockerfile the same way (its
Python is built from source into ``/usr/local``, Debian's lives in ``/usr``; both are CPython 3.11
on bookworm). Everything above the ``FROM`` line is the project's own and is exercised as is.

The machine's limits, not the image's: podman asks for open-file and process limits above what
these virtual machines allow (runc fails with ``setrlimit ... operation not permitted``), so the
engine gets a ``containers.conf`` (through ``CONTAINERS_CONF``) whose default limits fit. The
engine's own messages about a missing systemd are harmless here: health checks are run with
``podman healthcheck run`` (without systemd no timer runs them).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from tests.release.dockerfile import DOCKERFILE, REPO, instructions

ENGINE = ("podman", "--runtime", "runc", "--cgroup-manager", "cgroupfs")
ULIMITS = ("nofile=4096:4096", "nproc=4096:4096")
SUITE = "bookworm"
PACKAGES = ("python3", "python3-pip", "ca-certificates")
HOST_CA_DIR = Path("/usr/local/share/ca-certificates")   # a machine's own CAs (an egress proxy's)
DEFAULT_MIRROR = "http://deb.debian.org/debian"


class ContainerError(RuntimeError):
    """An engine command failed: the command, its status and the end of its output."""


@dataclass
class Engine:
    """podman with runc and cgroupfs, configured by a containers.conf of its own."""

    conf_dir: Path
    env: dict[str, str] = field(default_factory=dict)
    log: list[str] = field(default_factory=list)     # every command run, with its time

    @classmethod
    def create(cls, conf_dir: Path) -> Engine:
        conf_dir.mkdir(parents=True, exist_ok=True)
        conf = conf_dir / "containers.conf"
        limits = ", ".join(f'"{u}"' for u in ULIMITS)
        conf.write_text(f"[containers]\ndefault_ulimits = [{limits}]\n")
        return cls(conf_dir=conf_dir, env={**os.environ, "CONTAINERS_CONF": str(conf)})

    def run(self, args: Sequence[str], timeout_s: float = 900.0, check: bool = True,
            input_bytes: bytes | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
        """``podman ARGS`` (with the runtime flags); raises ContainerError when it fails."""
        cmd = [*ENGINE, *args]
        t0 = time.monotonic()
        result = subprocess.run(cmd, capture_output=True, timeout=timeout_s, env=self.env, cwd=cwd,
                                input=input_bytes, check=False)
        self.log.append(f"{time.monotonic() - t0:7.2f} s  {' '.join(cmd)}")
        if check and result.returncode != 0:
            out = (result.stdout + result.stderr).decode(errors="replace")
            raise ContainerError(f"{' '.join(cmd)} exited {result.returncode}:\n{out[-4000:]}")
        return result

    def text(self, args: Sequence[str], timeout_s: float = 60.0) -> str:
        return self.run(args, timeout_s=timeout_s).stdout.decode().strip()

    def has_image(self, name: str) -> bool:
        return self.run(["image", "exists", name], check=False, timeout_s=60).returncode == 0


def missing_tools() -> list[str]:
    """The programs the sequence needs that this machine lacks."""
    return [tool for tool in ("podman", "runc", "debootstrap") if shutil.which(tool) is None]


def base_image(path: Path = DOCKERFILE) -> str:
    """The fully qualified name of the Dockerfile's one base image (every stage's FROM)."""
    bases = {args.split()[0] for keyword, args in instructions(path) if keyword == "FROM"}
    assert len(bases) == 1, f"one base image expected, the Dockerfile names {sorted(bases)}"
    name = bases.pop()
    if "/" not in name:
        name = f"docker.io/library/{name}"
    return name


def debian_mirror() -> str:
    """The machine's own Debian mirror (its apt sources), else deb.debian.org."""
    for source in (Path("/etc/apt/sources.list.d/debian.sources"), Path("/etc/apt/sources.list")):
        try:
            text = source.read_text()
        except OSError:
            continue
        for line in text.splitlines():
            words = line.split()
            if words[:1] == ["URIs:"] and len(words) > 1 and "security" not in words[1]:
                return words[1]
            if words[:1] == ["deb"] and len(words) > 2 and "security" not in words[-2]:
                return next(w for w in words[1:] if w.startswith("http"))
    return DEFAULT_MIRROR


def make_base(engine: Engine, name: str, work_dir: Path) -> float:
    """Build the stand-in for ``name`` from Debian's packages and import it; seconds taken."""
    t0 = time.monotonic()
    root = work_dir / "rootfs"
    subprocess.run(["debootstrap", "--variant=minbase", f"--include={','.join(PACKAGES)}", SUITE,
                    str(root), debian_mirror()], check=True, capture_output=True, timeout=1200)
    # the official image's shape: pip may install into the system Python, python and pip on PATH
    for marker in (root / "usr" / "lib").glob("python3*/EXTERNALLY-MANAGED"):
        marker.unlink()
    local_bin = root / "usr" / "local" / "bin"
    local_bin.mkdir(parents=True, exist_ok=True)
    (local_bin / "python").symlink_to("/usr/bin/python3")
    (local_bin / "pip").symlink_to("/usr/bin/pip3")
    lists = root / "var" / "lib" / "apt" / "lists"
    shutil.rmtree(lists, ignore_errors=True)
    lists.mkdir(parents=True)
    # this machine's own certificate authorities (an egress proxy's), so pip inside the build
    # reaches the package index as the host's pip does
    host_cas = sorted(HOST_CA_DIR.glob("*.crt")) if HOST_CA_DIR.is_dir() else []
    if host_cas:
        target = root / "usr" / "local" / "share" / "ca-certificates"
        target.mkdir(parents=True, exist_ok=True)
        for ca in host_cas:
            shutil.copy2(ca, target / ca.name)
        subprocess.run(["chroot", str(root), "update-ca-certificates"], check=True, capture_output=True,
                       timeout=120)
    archive = subprocess.run(["tar", "-C", str(root), "-c", "."], check=True, capture_output=True,
                             timeout=600).stdout
    engine.run(["import",
                "--change", "ENV PATH=/usr/local/bin:/usr/local/sbin:/usr/sbin:/usr/bin:/sbin:/bin",
                "--change", "ENV LANG=C.UTF-8", "--change", 'CMD ["python3"]', "-", name],
               input_bytes=archive, timeout_s=600)
    shutil.rmtree(root, ignore_errors=True)
    return time.monotonic() - t0


def build(engine: Engine, tag: str, cache: bool = True, context: Path = REPO) -> float:
    """``docker build -t TAG .`` as podman runs it here (``cache`` False: no layer cache);
    seconds taken."""
    t0 = time.monotonic()
    engine.run(["build", "--format", "docker", "--pull=never", *([] if cache else ["--no-cache"]), "-t", tag, "."],
               cwd=context, timeout_s=1800)
    return time.monotonic() - t0


def health(engine: Engine, container: str) -> tuple[int, str]:
    """Run the image's HEALTHCHECK once: (its exit status, the status the engine then reports)."""
    result = engine.run(["healthcheck", "run", container], check=False, timeout_s=60)
    status = engine.text(["inspect", "--format", "{{.State.Health.Status}}", container])
    return result.returncode, status


@dataclass(frozen=True)
class Stopped:
    seconds: float        # how long ``podman stop`` took
    exit_code: int        # the container's exit status
    oom_killed: bool


def stop(engine: Engine, container: str, timeout_s: int = 10) -> Stopped:
    """``docker stop`` (SIGTERM, SIGKILL after ``timeout_s``), timed; the exit status after."""
    t0 = time.monotonic()
    engine.run(["stop", "--time", str(timeout_s), container], timeout_s=timeout_s + 60)
    seconds = time.monotonic() - t0
    code, oom = engine.text(["inspect", "--format", "{{.State.ExitCode}} {{.State.OOMKilled}}", container]).split()
    return Stopped(seconds=seconds, exit_code=int(code), oom_killed=oom == "true")


def scratch_dir() -> Path:
    """A working directory for the root file system (on the same disk as the engine's storage)."""
    return Path(tempfile.mkdtemp(prefix="tauv-container-", dir="/var/tmp"))


@dataclass
class Figures:
    """What the sequence measured, in the order it ran."""

    base: str = ""                 # the base image's name
    base_made_s: float | None = None   # seconds to make the stand-in (None: the base was present)
    build_s: float = 0.0           # ``build`` of the unchanged Dockerfile
    serving_s: float = 0.0         # from ``run -d`` to the first GET / answering 200
    health_rc: int = -1            # the HEALTHCHECK's exit status
    health_status: str = ""        # what the engine reports after it
    pid1: str = ""                 # the process running as PID 1 in the container
    uid: str = ""                  # the user the server runs as
    run_s: float = 0.0             # a dashboard run in a browser: Run pressed to "Run complete"
    stop: Stopped | None = None

    def lines(self) -> list[str]:
        base = (f"stand-in made from Debian's packages in {self.base_made_s:.0f} s"
                if self.base_made_s is not None else "already present (not rebuilt)")
        stop = self.stop
        return [
            f"base image {self.base}: {base}",
            f"image built in {self.build_s:.0f} s",
            f"serving GET / (200) {self.serving_s:.1f} s after run -d; PID 1 {self.pid1}, uid {self.uid}",
            f"HEALTHCHECK exit status {self.health_rc}, health {self.health_status}",
            f"dashboard run in a browser complete {self.run_s:.1f} s after Run",
            (f"stop took {stop.seconds:.2f} s, exit status {stop.exit_code}" if stop else "not stopped"),
        ]


def wait_serving(url: str, timeout_s: float = 180.0) -> float:
    """Seconds until GET ``url`` answers 200; raises ContainerError after ``timeout_s``."""
    import urllib.request

    t0 = time.monotonic()
    while True:
        try:
            with urllib.request.urlopen(url, timeout=2) as response:
                if response.status == 200:
                    return time.monotonic() - t0
        except OSError:
            pass
        if time.monotonic() - t0 > timeout_s:
            raise ContainerError(f"{url} did not answer 200 within {timeout_s:.0f} s")
        time.sleep(0.25)


def sequence(engine: Engine, tag: str, container: str, port: int, use_dashboard: Callable[[str], float],
             work_dir: Path | None = None, cache: bool = True) -> Figures:
    """The Docker page's build, run, health, use and stop, with podman; the figures measured.

    The base is made only when the engine lacks it. The container runs without ``--rm`` so its
    exit status can be read after the stop; it is removed afterwards whatever happened.
    ``use_dashboard(url)`` completes a run on the served dashboard and returns its seconds."""
    figures = Figures(base=base_image())
    if not engine.has_image(figures.base):
        scratch = work_dir or scratch_dir()
        try:
            figures.base_made_s = make_base(engine, figures.base, scratch)
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
    figures.build_s = build(engine, tag, cache)
    engine.run(["rm", "--force", "--ignore", container], timeout_s=120)
    t0 = time.monotonic()
    engine.run(["run", "-d", "-p", f"127.0.0.1:{port}:8080", "--name", container, tag], timeout_s=120)
    try:
        url = f"http://127.0.0.1:{port}/"
        wait_serving(url)
        figures.serving_s = time.monotonic() - t0
        figures.pid1 = engine.text(["exec", container, "cat", "/proc/1/comm"])
        figures.uid = engine.text(["exec", container, "id", "-u"])
        figures.health_rc, figures.health_status = health(engine, container)
        figures.run_s = use_dashboard(url)
        figures.stop = stop(engine, container)
    finally:
        engine.run(["rm", "--force", "--ignore", container], check=False, timeout_s=120)
    return figures


def dashboard_run(browser, url: str, screenshot: Path | None = None) -> float:
    """Open the dashboard at ``url`` in ``browser`` (a Playwright Chromium), press Run with the
    default settings and wait for "Run complete"; the seconds from the press. The results table
    must list the methods run, and the page must have asked for nothing beyond this machine."""
    from tests.browser.conftest import THROTTLE_FRAMES, Tab

    context = browser.new_context(viewport={"width": 1500, "height": 950})
    try:
        context.add_init_script(THROTTLE_FRAMES)
        tab = Tab(context.new_page(), url)
        t0 = time.monotonic()
        tab.page.get_by_role("button", name="Run", exact=True).click()
        tab.notification("Run complete").wait_for(timeout=180_000)
        seconds = time.monotonic() - t0
        if screenshot is not None:
            tab.page.screenshot(path=str(screenshot))
        tab.page.get_by_role("tab", name="Results").click()
        table = tab.results_table()
        if not table:
            raise ContainerError("the run completed but the results table is empty")
        if tab.external_requests:
            raise ContainerError(f"the page asked beyond this machine: {tab.external_requests}")
        return seconds
    finally:
        context.close()
