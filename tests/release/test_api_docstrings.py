"""The API reference's docstrings are numpy style: every public function and method of a module
the reference shows (docs/api/*.md) names each of its parameters in a ``Parameters`` section and
says what it returns in ``Returns`` (or ``Yields``), with shapes and units where they apply.
Read from the source (no import), so a parameter added without its line fails here."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

pytestmark = pytest.mark.release

REPO = Path(__file__).resolve().parents[2]
SECTION = re.compile(r"^(Parameters|Returns|Yields|Raises|Notes|Examples|See Also|Attributes)\n-{3,}$", re.M)


def api_modules() -> list[str]:
    return sorted({m for page in (REPO / "docs" / "api").glob("*.md")
                   for m in re.findall(r"^::: ([\w.]+)$", page.read_text(encoding="utf-8"), re.M)})


def module_path(module: str) -> Path:
    path = REPO.joinpath(*module.split("."))
    return path / "__init__.py" if path.is_dir() else path.with_suffix(".py")


def public_functions(tree: ast.Module) -> list[tuple[str, ast.FunctionDef]]:
    out = [(n.name, n) for n in tree.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")]
    for cls in (n for n in tree.body if isinstance(n, ast.ClassDef) and not n.name.startswith("_")):
        out += [(f"{cls.name}.{n.name}", n) for n in cls.body
                if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")]
    return out


def decorators(node: ast.FunctionDef) -> set[str]:
    return {ast.unparse(d).split("(")[0].split(".")[-1] for d in node.decorator_list}


def sections(doc: str) -> dict[str, str]:
    """Section title -> its body, for the numpy-style sections of ``doc``."""
    marks = list(SECTION.finditer(doc))
    return {m.group(1): doc[m.end():marks[i + 1].start() if i + 1 < len(marks) else len(doc)]
            for i, m in enumerate(marks)}


def parameters(node: ast.FunctionDef) -> list[str]:
    args = node.args
    names = [a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs)]
    names += [a.arg for a in (args.vararg, args.kwarg) if a is not None]
    return [n for n in names if n not in ("self", "cls")]


def returns_value(node: ast.FunctionDef) -> bool:
    return node.returns is not None and ast.unparse(node.returns) not in ("None", "NoReturn", "Never")


def problems(module: str) -> list[str]:
    tree = ast.parse(module_path(module).read_text(encoding="utf-8"))
    found = []
    for name, node in public_functions(tree):
        if decorators(node) & {"property", "cached_property", "overload", "setter"}:
            continue
        doc = ast.get_docstring(node) or ""
        where = f"{module}.{name}"
        if not doc:
            found.append(f"{where}: no docstring")
            continue
        parts = sections(doc)
        wanted = parameters(node)
        if wanted:
            listed = set(re.findall(r"^\*{0,2}(\w+)\s*(?::|$)", parts.get("Parameters", ""), re.M))
            missing = [p for p in wanted if p not in listed]
            if missing:
                found.append(f"{where}: Parameters does not name {', '.join(missing)}")
        if returns_value(node) and not ({"Returns", "Yields"} & set(parts)):
            found.append(f"{where}: no Returns section")
    return found


def test_the_reference_shows_modules() -> None:
    assert len(api_modules()) >= 20


@pytest.mark.parametrize("module", api_modules())
def test_every_public_function_documents_its_parameters_and_result(module: str) -> None:
    found = problems(module)
    assert not found, "\n".join(found)
