"""Every file the project writes goes through one writer (`registry.atomic_write` and its module): no module
but `registry._atomic` writes, replaces or moves a file by itself, as `test_package_graph` checks imports."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.test_package_graph import ORDER, ROOT

#: The writer: the only module that may write, replace or move files.
WRITER = "registry/_atomic.py"
#: Methods that write a file at the path they are given (or at the path they are called on).
WRITING_METHODS = {
    "write_bytes",
    "write_text",
    "savefig",
    "to_parquet",
    "to_csv",
    "to_json",
    "write_table",
    "savez",
    "savez_compressed",
    "Save",
    "Export",
    "symlink_to",
    "hardlink_to",
    "touch",
}
#: Functions of ``os`` and ``shutil`` that create, replace or move files.
MOVING_FUNCTIONS = {
    ("os", "replace"),
    ("os", "rename"),
    ("os", "renames"),
    ("os", "link"),
    ("os", "symlink"),
    ("shutil", "copy"),
    ("shutil", "copy2"),
    ("shutil", "copyfile"),
    ("shutil", "copytree"),
    ("shutil", "move"),
}
#: Names of in-memory streams and of the temporary files the writer hands out: writing to those is fine.
STREAMS = {"buffer", "stream", "sink", "handle", "temporary"}


def _name(node: ast.expr) -> str:
    """``x`` for ``x``, ``str(x)`` and ``a.x``; "" for anything else."""
    if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "str" and node.args:
        return _name(node.args[0])
    if isinstance(node, ast.Name):
        return node.id
    return node.attr if isinstance(node, ast.Attribute) else ""


def _writes_to_a_stream(call: ast.Call) -> bool:
    """Whether a writing method's destination (its first argument, or the second of ``write_table``) is
    an in-memory stream or the writer's temporary file, or whether it has none (``to_csv()`` returns text;
    ``folder.save()`` is the project's own method)."""
    method = call.func.attr  # type: ignore[union-attr]
    arguments = call.args[1:] if method == "write_table" else call.args
    if method in ("write_bytes", "write_text", "touch", "symlink_to", "hardlink_to"):
        return False
    if not arguments:
        return method in ("to_csv", "to_json") and not any(
            keyword.arg == "path_or_buf" for keyword in call.keywords
        )
    return _name(arguments[0]) in STREAMS


def _mode(call: ast.Call) -> str:
    """The mode of an ``open`` call ("r" when absent or not a constant): the first argument of
    ``path.open``, the second of ``open``, ``io.open`` and ``os.fdopen``."""
    function = call.func
    on_a_path = isinstance(function, ast.Attribute) and _name(function.value) not in ("io", "os")
    candidates = [keyword.value for keyword in call.keywords if keyword.arg == "mode"]
    candidates += call.args[0:1] if on_a_path else call.args[1:2]
    constant = next((node.value for node in candidates if isinstance(node, ast.Constant)), "r")
    return constant if isinstance(constant, str) else "r"


def direct_writes(path: Path) -> list[str]:
    """``line: call`` of every place in ``path`` that writes, replaces or moves a file by itself."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if not isinstance(node, ast.Call):
            continue
        function = node.func
        text = ast.unparse(function)
        if isinstance(function, ast.Attribute):
            owner = _name(function.value)
            if (owner, function.attr) in MOVING_FUNCTIONS:
                found.append(f"{node.lineno}: {text}")
            elif function.attr in WRITING_METHODS and not _writes_to_a_stream(node):
                found.append(f"{node.lineno}: {text}")
            elif (owner, function.attr) == ("os", "open"):
                flags = ast.unparse(node.args[1]) if len(node.args) > 1 else ""
                if any(flag in flags for flag in ("O_WRONLY", "O_RDWR", "O_CREAT")):
                    found.append(f"{node.lineno}: {text}")
            elif function.attr in ("open", "fdopen") and set(_mode(node)) & set("wax+"):
                found.append(f"{node.lineno}: {text}")
        elif isinstance(function, ast.Name) and function.id == "open" and set(_mode(node)) & set("wax+"):
            found.append(f"{node.lineno}: {text}")
    return found


@pytest.mark.parametrize("package", ORDER)
def test_no_module_writes_a_file_but_through_the_writer(package: str) -> None:
    writes = {
        str(path.relative_to(ROOT)): direct_writes(path)
        for path in sorted((ROOT / package).rglob("*.py"))
        if str(path.relative_to(ROOT)) != WRITER and direct_writes(path)
    }
    assert writes == {}


@pytest.mark.parametrize(
    "source",
    [
        'Path("x").write_text("y")',
        'open(path, "w")',
        'open(path, mode="ab")',
        'path.open("wb")',
        "os.replace(a, b)",
        "shutil.copyfile(a, b)",
        "np.savez_compressed(path, x=x)",
        "figure.savefig(path)",
        "frame.to_csv(path)",
        "pq.write_table(table, path)",
        "stage.GetRootLayer().Save()",
        "os.open(path, os.O_WRONLY | os.O_CREAT)",
    ],
)
def test_the_scan_finds_each_kind_of_direct_write(tmp_path, source: str) -> None:
    module = tmp_path / "module.py"
    module.write_text(source + "\n")
    assert direct_writes(module) == [f"1: {ast.unparse(ast.parse(source).body[0].value.func)}"]


@pytest.mark.parametrize(
    "source",
    [
        'open(path, encoding="utf-8")',
        'path.open("rb")',
        'figure.savefig(buffer, format="png")',
        "image.save(buffer)",
        "folder.save()",
        "pq.write_table(table, sink)",
        "np.savez_compressed(stream, x=x)",
        "frame.to_csv(index=False)",
        "os.open(path, os.O_RDONLY)",
        "layer.Export(str(temporary))",
    ],
)
def test_the_scan_lets_reads_and_in_memory_writes_pass(tmp_path, source: str) -> None:
    module = tmp_path / "module.py"
    module.write_text(source + "\n")
    assert direct_writes(module) == []
