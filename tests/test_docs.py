"""The README stays short and its links hold: at most 150 lines, the two set-up commands in fenced bash blocks,
and every relative link in README.md and docs/*.md names a file that exists and, with a ``#anchor``, a heading
of that file (GitHub's slugs). No network: external links are not followed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
MAX_README_LINES = 150

FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
INLINE_CODE = re.compile(r"`+[^`\n]*`+")
# [text](target) or [text](target "title"); images too (the leading ! is not needed to match)
LINK = re.compile(r"\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^ {0,3}(#{1,6})[ \t]+(.+?)[ \t]*#*[ \t]*$", re.MULTILINE)
EXTERNAL = re.compile(r"^(?:[a-z][a-z0-9+.-]*:|//)", re.IGNORECASE)


def markdown_files() -> list[Path]:
    return [README, *sorted((ROOT / "docs").glob("*.md"))]


def without_fences(text: str) -> str:
    """The text with its fenced blocks blanked, line count kept (a `#` comment in code is no heading)."""
    return FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)


def without_code(text: str) -> str:
    """The text with fenced blocks and inline code blanked (a link in code is no link)."""
    return INLINE_CODE.sub("", without_fences(text))


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: markup dropped, lowercase, punctuation but hyphens and spaces stripped,
    spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link in a heading keeps its text
    text = text.replace("`", "").lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every heading's slug in a markdown file, repeated headings numbered as GitHub does (-1, -2, ...)."""
    seen: dict[str, int] = {}
    out = set()
    for m in HEADING.finditer(without_fences(path.read_text(encoding="utf-8"))):
        base = slug(m.group(2))
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def relative_links(path: Path) -> list[str]:
    return [t for t in LINK.findall(without_code(path.read_text(encoding="utf-8"))) if not EXTERNAL.match(t)]


def broken_links(path: Path) -> list[str]:
    """Each relative link of ``path`` that names a missing file or a heading its file lacks."""
    broken = []
    for target in relative_links(path):
        file_part, _, anchor = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        if not dest.exists():
            broken.append(f"{target}: no file {dest}")
        elif anchor and (dest.suffix != ".md" or anchor.lower() not in anchors(dest)):
            broken.append(f"{target}: no heading #{anchor} in {dest}")
    return broken


def test_readme_is_short():
    n = len(README.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_README_LINES, f"README.md has {n} lines, at most {MAX_README_LINES}: move detail to docs/"


def test_readme_has_the_two_setup_commands():
    blocks = [(lang.strip(), body) for lang, body in FENCE.findall(README.read_text(encoding="utf-8"))]
    bash = [body for lang, body in blocks if lang == "bash"]
    assert len(bash) == 2, f"README.md has {len(bash)} fenced bash blocks, expected the two set-up commands"
    install, tests = bash
    assert "pip install" in install and "dvc repro" in install, install
    assert "pytest" in tests and "dvc repro" not in tests, tests


def test_docs_pages_link_back_to_the_readme():
    for page in sorted((ROOT / "docs").glob("*.md")):
        lines = page.read_text(encoding="utf-8").splitlines()
        assert lines and lines[0].startswith("# "), f"{page.name}: starts with a one-line title"
        assert "../README.md" in relative_links(page), f"{page.name}: links back to the README"


@pytest.mark.parametrize("path", markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(path: Path):
    assert broken_links(path) == []


def test_a_broken_link_is_caught(tmp_path: Path):
    (tmp_path / "target.md").write_text("# A title\n\n## Across seeds: `hev robustness`\n", encoding="utf-8")
    page = tmp_path / "page.md"
    page.write_text(
        "[ok](target.md#across-seeds-hev-robustness) [ok](#local) [web](https://example.org/x.md)\n"
        "## Local\n"
        "[missing file](nowhere.md) [missing heading](target.md#across-seeds)\n"
        "```bash\n[in code](also-nowhere.md)\n```\n",
        encoding="utf-8",
    )
    found = broken_links(page)
    assert len(found) == 2, found
    assert found[0].startswith("nowhere.md") and found[1].startswith("target.md#across-seeds:")


def test_slug_is_githubs():
    assert slug("Set up (fresh machine, Python 3.11)") == "set-up-fresh-machine-python-311"
    assert slug("Across seeds: `hev robustness`") == "across-seeds-hev-robustness"
    assert slug("Does the surrogate earn its place? The equal-budget benchmark") == (
        "does-the-surrogate-earn-its-place-the-equal-budget-benchmark"
    )
