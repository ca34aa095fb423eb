"""The Python code the READMEs show runs as shown: each page's ```python blocks, in order, in
one namespace (a later block uses an earlier one's imports), from the repository's root (the
paths they name are relative to it)."""

import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", ROOT / "python" / "README.md"]


def blocks(text):
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_the_extraction_finds_the_blocks():
    sample = "text\n```python\nx = 1\n```\n```sh\nls\n```\n```python\ny = x + 1\n```\n"
    assert blocks(sample) == ["x = 1\n", "y = x + 1\n"]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_blocks_left_out_are_only_the_pytorch_ones(page):
    """```py blocks are not run: only the TorchRL example is one (PyPI's PyTorch, with its
    CUDA libraries, is more than CI can install; python/README.md shows its output)."""
    for code in re.findall(r"^```py\n(.*?)^```", page.read_text(), flags=re.S | re.M):
        assert "torchrl" in code, f"{page.name}: a ```py block that is not the TorchRL example is never run:\n{code}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_python_block_runs(page, monkeypatch):
    found = blocks(page.read_text())
    assert found, f"{page}: no ```python block found"
    monkeypatch.chdir(ROOT)
    namespace = {"__name__": "__readme__"}
    for i, code in enumerate(found):
        try:
            exec(compile(code, f"{page.name} block {i + 1}", "exec"), namespace)
        except Exception as e:  # the block and its error, not only the traceback's last line
            raise AssertionError(f"{page.name}, python block {i + 1} fails:\n{code}\n{type(e).__name__}: {e}") from e
