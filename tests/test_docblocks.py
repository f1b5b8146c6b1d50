"""The generated blocks of the README and docs/*.md (benchmarks/blocks.py): every marker has its
partner, every block a script writes is on its page, and a block is replaced between its own
markers only. No timing: the scripts themselves run in `make bench`."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from blocks import BlockError, markers, names, problems, replace_block  # noqa: E402

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_marker_has_its_partner(page):
    assert problems(page.read_text()) == []


def test_docs_script_writes_exactly_the_blocks_the_pages_hold():
    """docs.py's list of (page, block) is the pages' markers, both ways: no block left stale and no
    block written nowhere."""
    spec = importlib.util.spec_from_file_location("docs_bench", ROOT / "benchmarks" / "docs.py")
    docs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(docs)
    on_pages = {(p.name, n) for p in PAGES[1:] for n in names(p.read_text())}
    assert set(docs.BLOCKS) == on_pages
    assert names((ROOT / "README.md").read_text()) == [None]


def test_replace_block_touches_only_its_own_block():
    text = ("intro 1.5 s\n<!-- benchmark:a:start -->\nold a\n<!-- benchmark:a:end -->\nmiddle 42 %\n"
            "<!-- benchmark:b:start -->\nold b\n<!-- benchmark:b:end -->\ntail 7×\n")
    out = replace_block(text, "a", "new a\n")
    assert out == text.replace("old a", "new a")
    out = replace_block(out, "b", "\n\nnew b, two\nlines\n")
    assert out == ("intro 1.5 s\n<!-- benchmark:a:start -->\nnew a\n<!-- benchmark:a:end -->\nmiddle 42 %\n"
                   "<!-- benchmark:b:start -->\nnew b, two\nlines\n<!-- benchmark:b:end -->\ntail 7×\n")
    assert replace_block(out, "b", "new b, two\nlines") == out  # idempotent
    # the README's unnamed block is not a named one's, nor the other way round
    readme = "x\n<!-- benchmark:start -->\nold\n<!-- benchmark:end -->\ny\n"
    assert replace_block(readme, None, "new") == readme.replace("old", "new")
    with pytest.raises(BlockError):
        replace_block(readme, "a", "new")


@pytest.mark.parametrize("bad", [
    "<!-- benchmark:a:start -->\nno end\n",
    "no start\n<!-- benchmark:a:end -->\n",
    "<!-- benchmark:a:end -->\nreversed\n<!-- benchmark:a:start -->\n",
    "<!-- benchmark:a:start -->\n1\n<!-- benchmark:a:end -->\n<!-- benchmark:a:start -->\n2\n<!-- benchmark:a:end -->\n",
])
def test_bad_markers_are_refused_and_reported(bad):
    with pytest.raises(BlockError):
        replace_block(bad, "a", "new")
    assert problems(bad)


def test_problems_finds_a_block_inside_another_and_a_stray_end():
    start_a, end_a = markers("a")
    start_b, end_b = markers("b")
    assert problems(f"{start_a}\n{start_b}\n{end_b}\n{end_a}\n")
    assert problems(f"{start_a}\n{end_a}\n{end_b}\n")
    assert problems(f"{start_a}\n{end_a}\n{start_b}\n{end_b}\n") == []



def test_every_option_of_every_command_is_in_the_readme_or_docs():
    # before: build's --no-evidence, --no-clear, --min-hole-area, --simplify and --quiet, and
    # grid's --quiet, were in --help only
    from fuzzybrep import cli

    import re

    text = "".join(p.read_text(encoding="utf-8") for p in PAGES)
    sub = next(a for a in cli.parser()._actions if a.dest == "command")
    missing = [f"{name} {opt}" for name, sp in sub.choices.items() for a in sp._actions
               for opt in a.option_strings if opt not in ("-h", "--help")
               and not re.search(rf"(?<![\w-]){opt}(?![\w-])", text)]
    assert missing == []
