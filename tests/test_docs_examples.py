"""Every shell example of the docs pages runs as the page shows it (issue 23).

The pages' ```` ```console ```` blocks are extracted and run in a fresh folder per page, in order
(docs/_ext/docs_examples.py says how a block is read); a command must exit 0 (or the block's
documented ``exit=N``) and, where the page shows output, print it. Blocks marked ``slow`` or
``cluster`` (optimizer runs, FMU compilations, long sweeps, a Dask cluster) are left to
``python benchmarks/docs_examples.py --slow``; this test checks that they are few and that they
still parse as commands the command line accepts. The fast ones took about 1 min of CPU
(7 min wall on the shared 2-core machine at load 14).
"""
from __future__ import annotations

import shlex
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))

import docs_examples as ex  # noqa: E402

PAGES = {str(p.relative_to(ex.DOCS)): ex.parse_page(p) for p in ex.pages()}


def test_the_pages_have_examples_and_few_are_slow():
    blocks = [b for blocks, _ in PAGES.values() for b in blocks]
    assert len(blocks) >= 20
    assert sum(b.slow for b in blocks) <= len(blocks) // 2
    assert any("tutorial/first_gearbox.md" == b.page for b in blocks)


def test_matching_with_elisions():
    assert ex.matches(["a", "...", "d"], ["a", "b", "c", "d"])
    assert ex.matches(["a", "..."], ["a"])
    assert not ex.matches(["a", "d"], ["a", "b", "d"])
    assert not ex.matches(["x"], [])


def test_every_transgen_command_of_the_pages_parses():
    """Also the slow ones: the parser accepts each ``transgen`` command of every block."""
    from transgen.cli import build_parser

    parser = build_parser()
    for blocks, _ in PAGES.values():
        for block in blocks:
            for command in block.commands:
                for part in command.text.replace("\\\n", " ").split("&&"):
                    words = shlex.split(part.split("|")[0].split(">")[0], comments=True)
                    if words and words[0] == "transgen":
                        parser.parse_args(words[1:])


@pytest.mark.parametrize("page", sorted(p for p, (blocks, _) in PAGES.items() if any(not b.slow for b in blocks)))
def test_page_examples_run(page, tmp_path):
    blocks, files = PAGES[page]
    ex.prepare(tmp_path, files)
    problems = []
    for block in blocks:
        if not block.slow:
            problems += ex.check_block(block, tmp_path)
    assert not problems, "\n\n".join(problems)
