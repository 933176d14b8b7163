"""``docs/`` is guides plus measurement logs, and its index is current: every page is listed in
``docs/index.md``, every relative link of a page leads to a file, a guide stays within about 400
lines, and every log says when it was measured (dates) and at which commit."""
from __future__ import annotations

import re

import pytest

import tests

DOCS = tests.ROOT / "docs"
GUIDES = sorted(p.name for p in DOCS.glob("*.md") if p.name != "index.md")
LOGS = sorted(p.name for p in (DOCS / "log").glob("*.md"))
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
#: "at most about 400 lines": the guides' limit, with a few lines of slack
GUIDE_LINES = 420


def _links(path) -> list[str]:
    return [t for t in LINK.findall(path.read_text()) if not re.match(r"[a-z]+:", t)]


def test_the_index_lists_every_page_and_log():
    listed = set(_links(DOCS / "index.md"))
    assert set(GUIDES) <= listed, sorted(set(GUIDES) - listed)
    assert {f"log/{n}" for n in LOGS} <= listed, sorted({f"log/{n}" for n in LOGS} - listed)


@pytest.mark.parametrize("page", ["index.md"] + GUIDES + [f"log/{n}" for n in LOGS])
def test_relative_links_lead_to_files(page):
    path = DOCS / page
    broken = [t for t in _links(path) if not (path.parent / t).exists()]
    assert not broken, broken


@pytest.mark.parametrize("page", GUIDES)
def test_a_guide_stays_a_guide(page):
    assert len((DOCS / page).read_text().splitlines()) <= GUIDE_LINES


@pytest.mark.parametrize("log", LOGS)
def test_a_log_gives_dates_and_commits(log):
    text = (DOCS / "log" / log).read_text()
    assert re.search(r"\b20\d\d-\d\d-\d\d\b", text) and re.search(r"\b[0-9a-f]{7,40}\b", text)
