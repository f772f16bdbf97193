"""Read the repository's Dockerfile as an engine would: instructions (continuation lines joined,
comments dropped) and the exec-form (JSON) arguments of CMD, ENTRYPOINT and HEALTHCHECK."""

from __future__ import annotations

import json
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DOCKERFILE = REPO / "Dockerfile"


def instructions(path: Path = DOCKERFILE) -> list[tuple[str, str]]:
    """(KEYWORD, arguments) of every instruction, in order."""
    out: list[tuple[str, str]] = []
    pending = ""
    for raw in path.read_text().splitlines():
        line = raw.strip()
        if not pending and (not line or line.startswith("#")):
            continue
        if pending and line.startswith("#"):
            continue
        if line.endswith("\\"):
            pending += line[:-1] + " "
            continue
        full = (pending + line).strip()
        pending = ""
        keyword, _, args = full.partition(" ")
        out.append((keyword.upper(), args.strip()))
    return out


def final_stage(path: Path = DOCKERFILE) -> list[tuple[str, str]]:
    """The instructions of the last stage (the image that runs)."""
    items = instructions(path)
    last_from = max(i for i, (k, _) in enumerate(items) if k == "FROM")
    return items[last_from:]


def exec_form(keyword: str, path: Path = DOCKERFILE) -> list[str]:
    """The JSON argument list of the final stage's last ``keyword`` (CMD or ENTRYPOINT)."""
    args = [a for k, a in final_stage(path) if k == keyword]
    assert args, f"no {keyword} in the final stage of {path}"
    value = json.loads(args[-1])
    assert isinstance(value, list) and all(isinstance(v, str) for v in value), args[-1]
    return value


def healthcheck(path: Path = DOCKERFILE) -> tuple[list[str], list[str]]:
    """(options, exec-form command) of the final stage's HEALTHCHECK."""
    args = [a for k, a in final_stage(path) if k == "HEALTHCHECK"]
    assert args, "no HEALTHCHECK"
    options, sep, command = args[-1].partition("CMD ")
    assert sep, f"HEALTHCHECK without CMD: {args[-1]}"
    return options.split(), json.loads(command)
